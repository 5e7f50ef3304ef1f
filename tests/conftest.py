"""Shared fixtures: one tiny synthetic sequence rendered once per test session."""
from pathlib import Path

import pytest

from mmocap.data.synthetic import generate

TINY = dict(subject="S1", action="walking", frames=4, cameras=("C1", "C2", "BW1"),
            width=320, height=240, background_frames=3, seed=5)


@pytest.fixture(scope="session")
def tiny_sequence(tmp_path_factory) -> Path:
    """A 4-frame, 3-camera, 320x240 S1 walking sequence."""
    return generate(tmp_path_factory.mktemp("data") / "S1_walking", progress=False, **TINY)


def run_cli(*args) -> int:
    """``mmocap ARGS`` in this process; returns its exit status (0 when it returns)."""
    from mmocap.cli import main

    try:
        main([str(a) for a in args])
    except SystemExit as exc:
        return 0 if exc.code is None else exc.code
    return 0
