"""Bad recordings and recording settings, as a user meets them on the command line: one line
naming the file, camera or key, exit status 2."""

import shutil
from pathlib import Path

import pytest

from mmocap.data.recording.reader import write_recording
from mmocap.data.sequence import Sequence
from tests.helpers import assert_clean_error
from tests.helpers import mmocap_in_process as mmocap


@pytest.fixture(scope="module")
def tiny_recording(tiny_original, tmp_path_factory) -> Path:
    return write_recording(Sequence.open(tiny_original), tmp_path_factory.mktemp("rec") / "rec", progress=False)


@pytest.fixture
def recording(tiny_recording, tmp_path) -> Path:
    return Path(shutil.copytree(tiny_recording, tmp_path / "rec"))


def calibration_in_metres_without_saying(root: Path) -> list[str]:
    """A calibration whose translations are in neither mm nor m scale: ambiguous."""
    text = (root / "calibration.yml").read_text().replace("units: mm\n", "")
    lines = text.splitlines()
    in_t = False
    for k, line in enumerate(lines):  # t of every camera divided by 20: cameras about 200 units away
        if line.strip().startswith("t:"):
            in_t = True
        elif in_t and "data:" in line:
            head, _, values = line.partition("[")
            numbers = [float(v) / 20 for v in values.rstrip(" ]").split(",") if v.strip()]
            lines[k] = f"{head}[ {', '.join(map(repr, numbers))} ]"
            in_t = False
    (root / "calibration.yml").write_text("\n".join(lines) + "\n")
    return []


CASES = {
    "no-calibration": (
        lambda root: (root / "calibration.yml").unlink() or [],
        ["no calibration in recording", "calibration.yml"],
    ),
    "ambiguous-units": (calibration_in_metres_without_saying, ["calibration.yml", "dataset.units"]),
    "camera-without-video": (
        lambda root: (root / "videos" / "BW1.mp4").unlink() or ["dataset.cameras=[C1,BW1]"],
        ["camera BW1", "no video"],
    ),
    "offset-of-unknown-camera": (lambda root: ["dataset.offsets={C7:2}"], ["dataset.offsets", "C7"]),
    "unknown-up-axis": (lambda root: ["dataset.up=up"], ["dataset.up", "+z"]),
    "units-cm": (lambda root: ["dataset.units=cm"], ["dataset.units", "mm, m, auto"]),
    "no-background": (
        lambda root: shutil.rmtree(root / "background") or [],
        ["camera C1", "background", "dataset.background=[first,last]"],
    ),
    "start-mode": (lambda root: ["start.mode=sometimes"], ["start.mode", "auto, search"]),
    "body-height": (lambda root: ["body.height_mm=180"], ["body.height_mm", "1000"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_bad_recording_is_one_line(recording, tmp_path, case):
    breaker, culprits = CASES[case]
    extra = breaker(recording)
    outcome = mmocap(
        "track",
        "dataset=recording",
        f"dataset.root={recording}",
        "evaluator=numpy",
        "body.vertices=1000",
        "progress=false",
        "foreground_cache=null",
        f"hydra.run.dir={tmp_path / 'run'}",
        *extra,
    )
    assert_clean_error(outcome, *culprits)
