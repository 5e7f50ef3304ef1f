"""The tiny synthetic sequence and its HumanEva-I export, made once for every test here."""

import shutil
from pathlib import Path

import pytest

from mmocap.data.humaneva.export import export
from mmocap.data.synthetic import generate
from tests.helpers import HE_CAMERAS, HE_FRAMES


@pytest.fixture(scope="package")
def synthetic(tmp_path_factory) -> Path:
    return generate(
        tmp_path_factory.mktemp("synthetic") / "S1_walking",
        frames=HE_FRAMES,
        cameras=HE_CAMERAS,
        width=96,
        height=72,
        background_frames=3,
        seed=3,
        progress=False,
    )


@pytest.fixture(scope="package")
def exported(synthetic, tmp_path_factory) -> Path:
    return export(synthetic, tmp_path_factory.mktemp("humaneva"), progress=False)


@pytest.fixture
def damaged(exported, tmp_path) -> Path:
    """A private copy of the exported folder that a test may damage."""
    return Path(shutil.copytree(exported, tmp_path / "HumanEva"))
