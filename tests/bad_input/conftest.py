"""Fixtures of the bad-input corpus: each case builds one bad file, folder or option, runs
the command line and checks what a user sees (the runners and checks are in
:mod:`tests.helpers`).

A bad input must end in exactly one line ``mmocap: error: ...`` on stderr that names the
culprit (file, camera, key or column), exit status 2 and no traceback
(:func:`tests.helpers.assert_clean_error`). A questionable but usable input may instead run,
with a ``mmocap: warning: ...`` line that the run's ``summary.json`` records too
(:func:`tests.helpers.assert_warned`).

Every case works on its own copy of one tiny synthetic sequence (:func:`sequence_copy`).
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from mmocap.data.synthetic import generate
from tests.helpers import TINY_BAD_INPUT


@pytest.fixture(scope="session")
def tiny_original(tmp_path_factory) -> Path:
    """The tiny sequence, rendered once per session; cases copy it, never change it."""
    name = f"{TINY_BAD_INPUT['subject']}_{TINY_BAD_INPUT['action']}"
    return generate(tmp_path_factory.mktemp("bad_input") / name, progress=False, **TINY_BAD_INPUT)


@pytest.fixture
def sequence_copy(tiny_original, tmp_path) -> Path:
    """A fresh copy of the tiny sequence for one case to break: ``<tmp>/data/S1_walking``."""
    copy = tmp_path / "data" / tiny_original.name
    shutil.copytree(tiny_original, copy)
    return copy


def _mount(*args: str) -> bool:
    return subprocess.run(["mount", *args], capture_output=True).returncode == 0


@pytest.fixture
def small_disk(tmp_path):
    """A folder on a 256 KiB tmpfs, a disk that fills up (root only; skipped elsewhere)."""
    folder = tmp_path / "small_disk"
    folder.mkdir()
    if not _mount("-t", "tmpfs", "-o", "size=256k", "tmpfs", str(folder)):
        pytest.skip("cannot mount a tmpfs here (needs root): the full-disk case is not run")
    yield folder
    subprocess.run(["umount", "-l", str(folder)], capture_output=True)


@pytest.fixture
def make_read_only():
    """``make_read_only(folder)``: writes into ``folder`` then fail. As root, a read-only bind
    mount (root ignores permission bits); otherwise its write permissions are removed."""
    mounted, chmodded = [], []

    def make(folder: Path) -> Path:
        if os.geteuid() == 0:
            if not (_mount("--bind", str(folder), str(folder)) and _mount("-o", "remount,bind,ro", str(folder))):
                pytest.skip("cannot make a read-only bind mount here: the read-only case is not run")
            mounted.append(folder)
        else:
            for path in [folder, *folder.rglob("*")]:
                if path.is_dir():
                    path.chmod(0o555)
                    chmodded.append(path)
        return folder

    yield make
    for folder in reversed(mounted):
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)
    for path in chmodded:
        path.chmod(0o755)
