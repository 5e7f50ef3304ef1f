"""The sequence folder reader: metadata, images, markers and ground-truth coverage, each
checked as it is read (the command-line cases are in tests/bad_input/)."""

import inspect
import json
import shutil
import warnings

import cv2
import numpy as np
import pytest

from mmocap import config
from mmocap.body.model import MARKER_NAMES
from mmocap.camera import Camera
from mmocap.data.sequence import (
    MISSING_MARKERS_ACTIONS,
    Sequence,
    SequenceBase,
    check_missing_markers,
    read_image,
    read_meta,
    write_markers,
)
from mmocap.errors import ConfigError, DataError, MmocapWarning


@pytest.fixture
def folder(tiny_sequence, tmp_path):
    """A private copy of the shared tiny sequence (4 frames, C1, C2 and BW1)."""
    return shutil.copytree(tiny_sequence, tmp_path / "S1_walking")


def test_the_missing_markers_default_is_the_yaml_one():
    default = inspect.signature(SequenceBase.ground_truth).parameters["missing_markers"].default
    assert config.load("config.yaml").evaluation.missing_markers == default
    assert default in MISSING_MARKERS_ACTIONS


def test_a_good_folder_opens_with_its_cameras(folder):
    seq = Sequence.open(folder, ["BW1", "C1"])
    assert [c.name for c in seq.cameras] == ["BW1", "C1"]
    assert [c.colour for c in seq.cameras] == [False, True]
    grey, colour = seq.images(0)
    assert grey.shape == (240, 320)
    assert colour.shape == (240, 320, 3)
    assert grey.dtype == colour.dtype == np.uint8


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda m: m.pop("fps"), "lacks the key fps"),
        (lambda m: m.update(frames=True), "'frames' must be a positive integer, got True"),
        (lambda m: m.update(fps=float("nan")), "'fps' must be a positive number"),
        (lambda m: m.update(cameras=[]), "'cameras' must be a non-empty list"),
        (lambda m: m.update(marker_names=list(MARKER_NAMES[:-1])), "'marker_names' must be the body model's"),
        (lambda m: m["x0"].__setitem__(5, float("nan")), "'x0' must be the first frame's pose: a list of 51 finite"),
    ],
)
def test_read_meta_names_the_file_and_key(folder, change, message):
    path = folder / "sequence.json"
    meta = json.loads(path.read_text())
    change(meta)
    path.write_text(json.dumps(meta))
    with pytest.raises(DataError, match=f"sequence.json.*{message}"):
        read_meta(path)


def test_a_folder_without_sequence_json_is_not_a_sequence(tmp_path):
    with pytest.raises(DataError, match="not a sequence folder"):
        Sequence.open(tmp_path)


def test_the_calibration_of_another_camera_is_refused(folder):
    shutil.copy(folder / "calibration" / "C2.json", folder / "calibration" / "C1.json")
    with pytest.raises(DataError, match=r"camera C1: .*C1.json: 'name' is 'C2'"):
        Sequence.open(folder)


def test_missing_frames_are_listed_when_the_folder_opens(folder):
    for frame in (1, 3):
        (folder / "images" / "C2" / f"{frame:06d}.png").unlink()
    with pytest.raises(DataError, match=r"camera C2: .*C2 lacks 2 of the 4 frames .*: 000001.png, 000003.png"):
        Sequence.open(folder)


@pytest.fixture
def colour_camera():
    return Camera.look_at("C1", (3000, 1500, 0), (0, 900, 0), 300.0, 32, 24)


@pytest.mark.parametrize(
    ("image", "colour", "message"),
    [
        (np.zeros((24, 32), np.uint8), True, "has 1 channel, but the calibration says camera C1 is colour"),
        (np.zeros((24, 32, 3), np.uint8), False, "has 3 channels, but the calibration says camera C1 is greyscale"),
        (np.zeros((24, 32, 4), np.uint8), True, "has 4 channels"),
        (np.zeros((24, 32, 3), np.uint16), True, "has uint16 pixels"),
        (np.zeros((20, 32, 3), np.uint8), True, "is 32x20, calibration says 32x24"),
    ],
)
def test_read_image_takes_the_file_as_it_is(tmp_path, colour_camera, image, colour, message):
    path = tmp_path / "000000.png"
    cv2.imwrite(str(path), image)
    camera = (
        colour_camera if colour else Camera.look_at("C1", (3000, 1500, 0), (0, 900, 0), 300.0, 32, 24, colour=False)
    )
    with pytest.raises(DataError, match=f"camera C1: image .*000000.png {message}"):
        read_image(path, camera)


def test_read_image_refuses_damaged_and_missing_files(tmp_path, colour_camera):
    path = tmp_path / "000000.png"
    path.write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    with pytest.raises(DataError, match="camera C1: cannot read image .*000000.png"):
        read_image(path, colour_camera)
    with pytest.raises(DataError, match="camera C1: image not found: .*000001.png"):
        read_image(tmp_path / "000001.png", colour_camera)


def test_markers_round_trip_with_missing_coordinates_and_a_trailing_blank_line(folder):
    seq = Sequence.open(folder)
    truth = seq.markers()
    truth[2, 3] = np.nan  # one marker missing: its cells are empty
    write_markers(folder / "markers_mm.csv", truth, MARKER_NAMES)
    with open(folder / "markers_mm.csv", "a") as f:
        f.write("\n")
    np.testing.assert_allclose(seq.markers(), truth, atol=5e-4)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda lines: lines + [lines[1]], "frame 0 marker head appears 2 times"),
        (
            lambda lines: [lines[0], "x,head,1,2,3"] + lines[2:],
            r"column 'frame' must hold integer .* line 2: x,head,1,2,3",
        ),
        (lambda lines: lines + ["9,head,1,2,3"], r"frame 9 is outside the sequence's 4 frames \(0-3\)"),
        (lambda lines: lines + ["1,tail,1,2,3"], r"unknown marker names \['tail'\]"),
        (lambda lines: [lines[0].replace("y_mm", "why")] + lines[1:], "lacks the column y_mm"),
    ],
)
def test_bad_marker_tables_name_the_file_and_the_line(folder, edit, message):
    path = folder / "markers_mm.csv"
    path.write_text("\n".join(edit(path.read_text().splitlines())) + "\n")
    with pytest.raises(DataError, match=f"markers_mm.csv:? {message}"):
        Sequence.open(folder).markers()


def without_frames(folder, frames):
    seq = Sequence.open(folder)
    truth = seq.markers()
    truth[list(frames)] = np.nan
    write_markers(folder / "markers_mm.csv", truth, MARKER_NAMES)
    return seq


def test_ground_truth_of_every_frame_gives_no_warning(folder):
    seq = Sequence.open(folder)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        truth = seq.ground_truth(4, "stop")
    np.testing.assert_array_equal(truth, seq.markers())


def test_frames_without_ground_truth_warn_or_stop(folder):
    seq = without_frames(folder, [1, 3])
    with pytest.warns(
        MmocapWarning,
        match=r"markers_mm.csv: 2 of the 4 tracked frames \(frames 1, 3\) have no "
        "ground-truth markers: the marker error is over the 2 frames scored",
    ):
        truth = seq.ground_truth(4)
    assert np.isnan(truth[[1, 3]]).all()
    assert not np.isnan(truth[[0, 2]]).any()
    with pytest.raises(
        DataError,
        match=r"markers_mm.csv: 2 of the 4 tracked frames \(frames 1, 3\) have no "
        "ground-truth markers; .*evaluation.missing_markers=warn",
    ):
        seq.ground_truth(4, "stop")


def test_only_the_tracked_frames_count(folder):
    seq = without_frames(folder, [3])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert seq.ground_truth(3, "stop").shape == (3, len(MARKER_NAMES), 3)


def test_no_ground_truth_at_all(folder):
    seq = without_frames(folder, range(4))
    with pytest.warns(MmocapWarning, match="none of the 4 tracked frames has ground-truth markers: .*null"):
        seq.ground_truth(4)
    with pytest.raises(DataError, match="none of the 4 tracked frames has"):
        seq.ground_truth(4, "stop")


def test_an_unknown_missing_markers_action_is_a_config_error():
    with pytest.raises(ConfigError, match="evaluation.missing_markers must be one of warn, stop, score, got 'skip'"):
        check_missing_markers("skip")
