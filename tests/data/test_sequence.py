"""The sequence folder reader: metadata, images, markers and ground-truth coverage, each
checked as it is read (the command-line cases are in tests/bad_input/)."""

import inspect
import json
import shutil
import tempfile
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mmocap import config
from mmocap.body.model import MARKER_NAMES
from mmocap.camera import Camera
from mmocap.data.sequence import (
    MISSING_MARKERS_ACTIONS,
    Sequence,
    SequenceBase,
    check_missing_markers,
    read_image,
    read_markers,
    read_meta,
    write_markers,
)
from mmocap.errors import ConfigError, DataError, MmocapWarning
from tests.helpers import damages, read_damaged, read_or_refused


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


# --- files cut short or damaged (Hypothesis: tests/helpers.py damages) -----------------------

#: the small marker table the property tests damage: 2 frames of every marker, mm
SMALL_MARKERS = np.round(np.random.default_rng(3).uniform(-900, 1800, (2, len(MARKER_NAMES), 3)), 3)


@pytest.fixture(scope="module")
def marker_file(tmp_path_factory):
    """``markers_mm.csv`` of :data:`SMALL_MARKERS` (write_markers) and its bytes; each example
    writes its damaged copy beside it."""
    path = tmp_path_factory.mktemp("markers") / "markers_mm.csv"
    write_markers(path, SMALL_MARKERS, MARKER_NAMES)
    return path, path.read_bytes()


def read_small_markers(path):
    return read_markers(path, len(SMALL_MARKERS), list(MARKER_NAMES))


@settings(max_examples=100)
@given(data=st.data())
def test_a_cut_marker_file_is_refused_or_read_as_its_whole_rows(marker_file, data):
    """A cut inside a row is refused (a cut number would read as another); a cut at a row's
    end gives exactly the rows kept, every other marker NaN."""
    path, whole = marker_file
    damage = data.draw(damages(whole, ("cut",)))
    outcome = read_damaged(read_small_markers, path, damage, whole)
    rows = damage.whole_lines(whole) - 1  # the header is the first line
    if damage.offset == 0 or not whole[: damage.offset].endswith(b"\n") or rows < 1:
        assert outcome is None, f"{damage}: read, not refused"
        return
    assert outcome is not None, f"{damage}: refused, but {rows} whole rows were kept"
    expected = np.full_like(SMALL_MARKERS, np.nan).reshape(-1, 3)
    expected[:rows] = SMALL_MARKERS.reshape(-1, 3)[:rows]
    np.testing.assert_array_equal(outcome[0], expected.reshape(SMALL_MARKERS.shape))


@settings(max_examples=100)
@given(data=st.data())
def test_a_damaged_byte_of_a_marker_file_changes_one_marker_at_most(marker_file, data):
    """A byte changed is refused, or read as the file says: one marker of one frame at most
    differs from the whole file's (a digit for a digit cannot be told without a checksum)."""
    path, whole = marker_file
    damage = data.draw(damages(whole, ("byte",)))
    outcome = read_damaged(read_small_markers, path, damage, whole)
    if outcome is not None:
        differs = ~((outcome[0] == SMALL_MARKERS) | (np.isnan(outcome[0]) & np.isnan(SMALL_MARKERS))).all(axis=2)
        assert differs.sum() <= 1, f"{damage}: {differs.sum()} markers differ"


@settings(max_examples=50)
@given(data=st.data())
def test_ground_truth_of_a_file_cut_at_a_row_end_scores_whole_frames_only(marker_file, data):
    """The issue's case: a file cut after frame 1's seventh marker. Its frames are whole or
    not scored (all NaN), with a warning naming each frame lacking markers and its count;
    ``score`` keeps the partial frame's markers, ``stop`` refuses."""
    path, whole = marker_file
    lines = whole.splitlines(keepends=True)
    rows = data.draw(st.integers(1, len(lines) - 2), label="rows kept")
    sequence = MarkerFile(path.with_name("damaged.csv"), len(SMALL_MARKERS))
    sequence.root.write_bytes(b"".join(lines[: rows + 1]))
    frame, present = divmod(rows, len(MARKER_NAMES))
    outcome = read_or_refused(sequence.ground_truth, str(sequence.root), len(SMALL_MARKERS))
    truth, messages = outcome
    whole_frames = np.isfinite(truth).all(axis=(1, 2))
    assert (whole_frames | np.isnan(truth).all(axis=(1, 2))).all(), "a partial frame left to be scored"
    np.testing.assert_array_equal(truth[whole_frames], SMALL_MARKERS[whole_frames])
    assert whole_frames.sum() == frame
    if present:
        assert any(f"frame {frame} has {present} of {len(MARKER_NAMES)} markers" in m for m in messages), messages
        scored = read_or_refused(sequence.ground_truth, str(sequence.root), len(SMALL_MARKERS), "score")[0]
        np.testing.assert_array_equal(scored[frame, :present], SMALL_MARKERS[frame, :present])
        assert read_or_refused(sequence.ground_truth, str(sequence.root), len(SMALL_MARKERS), "stop") is None
    assert bool(messages) == (frame < len(SMALL_MARKERS))


class MarkerFile(SequenceBase):
    """A sequence that is only its ``markers_mm.csv`` at ``root`` (for :meth:`ground_truth`)."""

    def __init__(self, path, frames: int):
        super().__init__(path, {"frames": frames, "marker_names": list(MARKER_NAMES)}, [])

    def images(self, frame):
        raise NotImplementedError

    def background(self, camera):
        raise NotImplementedError

    @property
    def markers_source(self) -> str:
        return str(self.root)

    def markers(self) -> np.ndarray:
        return read_markers(self.root, self.n_frames, list(MARKER_NAMES))


@settings(max_examples=60)
@given(data=st.data())
def test_a_damaged_sequence_json_is_refused_or_read_as_it_was(tiny_sequence, data):
    whole = (tiny_sequence / "sequence.json").read_bytes()
    damage = data.draw(damages(whole))
    folder = Path(tempfile.mkdtemp(dir=tiny_sequence.parent))
    try:
        path = folder / "sequence.json"
        path.write_bytes(damage.apply(whole))
        outcome = read_or_refused(read_meta, str(path), path)
        if damage.kind == "cut" and outcome is not None:
            assert whole[damage.offset :].strip() == b"", f"{damage}: a cut file read"
            assert outcome[0] == json.loads(whole)
    finally:
        shutil.rmtree(folder)
