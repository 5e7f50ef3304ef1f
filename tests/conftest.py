"""Shared fixtures: one tiny synthetic sequence rendered once per test session."""

from pathlib import Path

import pytest

from mmocap.data.synthetic import generate
from tests.helpers import TINY


@pytest.fixture(scope="session")
def tiny_sequence(tmp_path_factory) -> Path:
    """A 4-frame, 3-camera, 320x240 S1 walking sequence."""
    return generate(tmp_path_factory.mktemp("data") / "S1_walking", progress=False, **TINY)
