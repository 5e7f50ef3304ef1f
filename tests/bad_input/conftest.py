"""The bad-input corpus: each case builds one bad file, folder or option, runs the real
command line (``python -m mmocap ...`` in a subprocess) and checks what a user sees.

A bad input must end in exactly one line ``mmocap: error: ...`` on stderr that names the
culprit (file, camera, key or column), exit status 2 and no traceback
(:func:`assert_clean_error`). A questionable but usable input may instead run, with a
``mmocap: warning: ...`` line that the run's ``summary.json`` records too
(:func:`assert_warned`).

Every case works on its own copy of one tiny synthetic sequence (:func:`sequence_copy`).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from mmocap.data.synthetic import generate

#: the tiny sequence every case breaks a copy of: 2 frames, 2 cameras (one colour, one
#: greyscale), 160x120
TINY = dict(subject="S1", action="walking", frames=2, cameras=("C1", "BW1"), width=160, height=120,
            background_frames=3, seed=3)


def track_args(root: Path, out: Path) -> list[str]:
    """Overrides of a quick tracking run of the sequence folder ``root`` into ``out``."""
    return ["dataset=folder", f"dataset.root={root}", f"dataset.subject={TINY['subject']}",
            "evaluator=numpy", "body.vertices=1000", "tracking.evaluations=60", "overlays=1",
            "progress=false", "foreground_cache=null", f"hydra.run.dir={out}"]


@dataclass
class Outcome:
    """What the user saw: the exit status and both streams."""

    args: list[str]
    code: int
    stdout: str
    stderr: str

    def __str__(self) -> str:
        return (f"mmocap {' '.join(self.args)}\nexit status {self.code}\n"
                f"--- stderr ---\n{self.stderr[-3000:]}\n--- stdout ---\n{self.stdout[-1500:]}")


def mmocap(*args, cwd: Path | None = None, timeout: float = 300, env: dict | None = None) -> Outcome:
    """``python -m mmocap ARGS`` in a subprocess, as a user runs it."""
    args = [str(a) for a in args]
    environment = {**os.environ, "HYDRA_FULL_ERROR": "0", **(env or {})}
    done = subprocess.run([sys.executable, "-m", "mmocap", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, env=environment)
    return Outcome(args, done.returncode, done.stdout, done.stderr)


def assert_clean_error(outcome: Outcome, *culprits: str) -> str:
    """Exit status 2, no traceback, and one ``mmocap: error:`` line naming every culprit
    (case-insensitive); returns that line."""
    assert "Traceback" not in outcome.stderr, f"a traceback:\n{outcome}"
    assert outcome.code == 2, f"exit status {outcome.code}, expected 2:\n{outcome}"
    lines = [line for line in outcome.stderr.splitlines() if line.startswith("mmocap: error:")]
    assert len(lines) == 1, f"expected one 'mmocap: error:' line:\n{outcome}"
    for culprit in culprits:
        assert culprit.lower() in lines[0].lower(), f"the error does not name {culprit!r}:\n{outcome}"
    return lines[0]


def assert_warned(outcome: Outcome, summary: dict, *words: str) -> str:
    """Exit status 0, no traceback, a ``mmocap: warning:`` line naming every word, and the
    same warning in ``summary["warnings"]``; returns the line."""
    assert "Traceback" not in outcome.stderr, f"a traceback:\n{outcome}"
    assert outcome.code == 0, f"exit status {outcome.code}, expected 0:\n{outcome}"
    lines = [line for line in outcome.stderr.splitlines() if line.startswith("mmocap: warning:")
             and all(w.lower() in line.lower() for w in words)]
    assert lines, f"no warning naming {words}:\n{outcome}"
    recorded = [w for w in summary.get("warnings", []) if all(x.lower() in w.lower() for x in words)]
    assert recorded, f"summary.json does not record the warning {words}: {summary.get('warnings')}"
    return lines[0]


@pytest.fixture(scope="session")
def tiny_original(tmp_path_factory) -> Path:
    """The tiny sequence, rendered once per session; cases copy it, never change it."""
    return generate(tmp_path_factory.mktemp("bad_input") / f"{TINY['subject']}_{TINY['action']}",
                    progress=False, **TINY)


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
            if not (_mount("--bind", str(folder), str(folder))
                    and _mount("-o", "remount,bind,ro", str(folder))):
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
