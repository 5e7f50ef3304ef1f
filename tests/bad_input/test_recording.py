"""Bad recordings and recording settings, as a user meets them on the command line: one line
naming the file, camera or key, exit status 2."""

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from mmocap.data.recording.reader import write_recording
from mmocap.data.sequence import Sequence
from mmocap.stages import segmentation
from tests.helpers import QUICK_START, assert_clean_error, assert_warned, pad_calibration, write_masks
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
        lambda root: shutil.rmtree(root / "background") or ["foreground.method=plate"],
        ["camera C1", "background", "dataset.background=[first,last]"],
    ),
    "masks-without-one-camera": (
        lambda root: write_masks(root, cameras=["C1"]) or [],
        ["camera BW1", "none of this one", "masks"],
    ),
    "masks-wrong-count": (
        lambda root: write_masks(root, missing=1) or [],
        ["camera C1", "1 masks", "2 frames", "one mask per frame"],
    ),
    "masks-wrong-size": (
        lambda root: write_masks(root, size=(80, 60)) or [],
        ["camera C1", "80x60", "160x120", "at the frames' size"],
    ),
    "masks-method-without-masks": (lambda root: ["foreground.method=masks"], ["foreground.method=masks", "masks/"]),
    "unknown-foreground-method": (lambda root: ["foreground.method=magic"], ["foreground.method", "segmentation"]),
    "size-beyond-the-codec-padding": (
        lambda root: pad_calibration(root, 17) or [],
        ["camera C1", "160x120", "177x120"],
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


def track_recording(recording: Path, tmp_path: Path, *extra: str):
    return mmocap(
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


def test_no_plate_and_no_segmentation_extra_is_one_line_with_the_install_line(recording, tmp_path, monkeypatch):
    shutil.rmtree(recording / "background")
    monkeypatch.setattr(segmentation, "available", lambda: False)
    outcome = track_recording(recording, tmp_path)
    assert_clean_error(outcome, str(recording), "no empty-scene plate", segmentation.INSTALL, "masks/")


def test_a_mask_holding_two_people_is_tracked_with_one_warning_naming_the_camera(recording, tmp_path):
    write_masks(recording)
    for mask in (recording / "masks" / "C1").iterdir():  # two people-sized blocks in every mask of C1
        image = cv2.imread(str(mask), cv2.IMREAD_GRAYSCALE)
        image[20:100, 20:50] = 255
        image[20:100, 100:130] = 255
        cv2.imwrite(str(mask), image)
    for mask in (recording / "masks" / "BW1").iterdir():
        image = cv2.imread(str(mask), cv2.IMREAD_GRAYSCALE)
        image[20:100, 60:90] = 255
        cv2.imwrite(str(mask), image)
    outcome = track_recording(recording, tmp_path, "body.height_mm=1700", "body.girth=1", *QUICK_START)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert_warned(outcome, summary, "camera C1", "2 separate person-sized regions", "largest_only")


def test_a_frame_where_a_camera_finds_nobody_leaves_it_out_of_that_frame_with_a_warning(
    recording, tiny_original, tmp_path
):
    sequence = Sequence.open(tiny_original)
    write_masks(recording)
    for camera in sequence.cameras:  # the true silhouettes as the given masks, but C1's frame 1 blank
        for frame in range(sequence.n_frames):
            person = sequence.silhouette(frame, camera) & ~(camera.name == "C1" and frame == 1)
            cv2.imwrite(str(recording / "masks" / camera.name / f"{frame:04d}.png"), person.astype(np.uint8) * 255)
    outcome = track_recording(recording, tmp_path, "body.height_mm=1700", "body.girth=1", *QUICK_START)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["frames"] == 2
    assert_warned(outcome, summary, "camera C1", "nobody in its foreground in 1 of 2 frames (1)", "left out")
