"""mmocap.data.recording.reader: a sequence written as a user's recording reads back as the same
cameras, frames and ground truth; every way a recording can be wrong is one clear error."""

import shutil
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from mmocap.data.calibration import read_calibration
from mmocap.data.keypoints import openpose_path, write_openpose_json
from mmocap.data.recording.reader import CODEC_PADDING_PX, UP_AXES, RecordingDataset, turned, write_recording
from mmocap.data.sequence import Sequence
from mmocap.errors import ConfigError, DataError, MmocapWarning
from tests.helpers import pad_calibration, qtm_calibration_xml, vicon_calibration_xml, write_masks

OFFSETS = {"C2": 2}
YAW_DEG = 30.0


@pytest.fixture(scope="module")
def recording(tiny_sequence, tmp_path_factory) -> Path:
    """The tiny sequence as a recording: C2 started 2 frames early, the world turned by 30
    degrees, the calibration in metres, lossless videos."""
    out = tmp_path_factory.mktemp("recording") / "rec"
    return write_recording(
        Sequence.open(tiny_sequence), out, offsets=OFFSETS, yaw_deg=YAW_DEG, units="m", progress=False
    )


@pytest.fixture
def recording_copy(recording, tmp_path) -> Path:
    return Path(shutil.copytree(recording, tmp_path / "rec"))


def yaw_matrix(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def test_the_layout_written_holds_no_first_pose_and_no_subject(recording):
    assert sorted(p.name for p in recording.iterdir()) == ["background", "calibration.yml", "markers_mm.csv", "videos"]
    assert "units: m" in (recording / "calibration.yml").read_text()
    opened = RecordingDataset(str(recording), offsets=OFFSETS).open(progress=False)
    assert opened.x0 is None
    assert opened.subject is None


def test_a_recording_reads_back_as_its_sequence_in_a_turned_world(tiny_sequence, recording):
    original = Sequence.open(tiny_sequence)
    opened = RecordingDataset(str(recording), offsets=OFFSETS).open(progress=False)
    assert opened.n_frames == original.n_frames
    assert opened.fps == original.fps
    assert opened.meta["units"] == "m"
    world = yaw_matrix(YAW_DEG)
    for mine, theirs in zip(opened.cameras, original.cameras):
        assert mine.name == theirs.name
        assert mine.colour == theirs.colour
        np.testing.assert_allclose(mine.R, theirs.R @ world.T, atol=1e-12)
        np.testing.assert_allclose(mine.t, theirs.t, rtol=1e-12)
        point = np.array([[100.0, 900.0, -200.0]])  # the same pixel from the turned world's point
        np.testing.assert_allclose(mine.project(point @ world.T), theirs.project(point), atol=1e-6)
    for frame in (0, 3, 1):
        for mine, theirs in zip(opened.images(frame), original.images(frame)):
            np.testing.assert_array_equal(mine, theirs)  # lossless, and C2's offset undone
    for camera, theirs in zip(opened.cameras, original.cameras):
        assert len(opened.background(camera)) == len(original.background(theirs))
    np.testing.assert_allclose(opened.markers(), original.markers() @ world.T, atol=1e-3)


def test_without_its_offset_a_camera_shows_other_frames(recording):
    opened = RecordingDataset(str(recording)).open(progress=False)
    synced = RecordingDataset(str(recording), offsets=OFFSETS).open(progress=False)
    c2 = [c.name for c in opened.cameras].index("C2")
    assert not np.array_equal(opened.images(0)[c2], synced.images(0)[c2])
    np.testing.assert_array_equal(opened.images(2)[c2], synced.images(0)[c2])


def test_start_and_frames_select_a_window_with_its_ground_truth(recording):
    whole = RecordingDataset(str(recording), offsets=OFFSETS).open(progress=False)
    window = RecordingDataset(str(recording), offsets=OFFSETS, start=1, frames=2).open(progress=False)
    assert window.n_frames == 2
    np.testing.assert_array_equal(window.images(0)[0], whole.images(1)[0])
    np.testing.assert_allclose(window.markers(), whole.markers()[1:3])


def test_image_folders_and_a_background_range_read_as_videos_do(recording, recording_copy):
    videos = RecordingDataset(str(recording), offsets=OFFSETS).open(progress=False)
    for camera in videos.cameras:
        (recording_copy / "videos" / f"{camera.name}.mp4").unlink()
        folder = recording_copy / "images" / camera.name
        folder.mkdir(parents=True)
        source = videos.sources[videos.cameras.index(camera)]
        for k in range(source.count):
            frame = source.read(k)
            cv2.imwrite(str(folder / f"img_{k:04d}.png"), frame)
    shutil.rmtree(recording_copy / "background")
    images = RecordingDataset(
        str(recording_copy), offsets=OFFSETS, fps=60.0, background=[0, 1], background_frames=2
    ).open(progress=False)
    np.testing.assert_array_equal(images.images(3)[0], videos.images(3)[0])
    assert images.background_frames[0] == [0, 1]
    assert images.background_frames[1] == [2, 3]


@pytest.mark.parametrize("up", list(UP_AXES))
def test_every_up_axis_is_a_rotation_that_points_it_up(up):
    world = UP_AXES[up]
    np.testing.assert_allclose(world @ world.T, np.eye(3))
    assert np.linalg.det(world) == pytest.approx(1)
    axis = np.zeros(3)
    axis["xyz".index(up[1])] = 1.0 if up[0] == "+" else -1.0
    np.testing.assert_allclose(world @ axis, [0, 1, 0])


def test_a_z_up_calibration_is_turned_into_y_up(tiny_sequence):
    camera = Sequence.open(tiny_sequence).cameras[0]
    z_up = turned(camera, UP_AXES["+z"].T)  # the same camera in a world whose z points up
    back = turned(z_up, UP_AXES["+z"])
    np.testing.assert_allclose(back.R, camera.R, atol=1e-12)


#: the breaks of masks, sizes and the plate, each a function of the recording's folder
FOLDER_BREAKS = {
    "masks-of-one-camera": lambda root: write_masks(root, cameras=["C1"]),
    "masks-wrong-count": lambda root: write_masks(root, missing=1),
    "masks-wrong-size": lambda root: write_masks(root, size=(160, 120)),
    "beyond-the-codec-padding": lambda root: pad_calibration(root, CODEC_PADDING_PX + 1),
    "no-background": lambda root: shutil.rmtree(root / "background"),
}


@pytest.mark.parametrize("layout", ["calibration.qca.txt", "calibration.xcp", "calibration/Calib.qca.txt"])
def test_a_lab_calibration_is_found_and_opened(recording_copy, layout):
    """QTM's double suffix, Vicon's, and Pose2Sim's calibration/ folder holding one QTM file
    beside the images it was made from."""
    calibration = read_calibration(recording_copy / "calibration.yml")
    (recording_copy / "calibration.yml").unlink()
    path = recording_copy / layout
    if path.parent != recording_copy:
        (path.parent / "extrinsics").mkdir(parents=True)
        (path.parent / "extrinsics" / "C1.png").write_bytes(b"not read")
    cameras = [replace(c, dist=np.r_[c.dist[:2], 0, 0, c.dist[4]], _maps={}) for c in calibration.cameras]
    path.write_text((vicon_calibration_xml if layout.endswith(".xcp") else qtm_calibration_xml)(cameras))
    dataset = RecordingDataset(str(recording_copy), offsets=OFFSETS)
    assert dataset.calibration_path() == recording_copy / layout.split("/")[0]
    opened = dataset.open(progress=False)
    assert opened.meta["up"] == "+z"  # dataset.up=auto: QTM's and Vicon's labs have z up
    points = np.array([[0.0, 0.0, 0.0], [300.0, 900.0, -200.0]])
    for got, want in zip(opened.cameras, cameras, strict=True):
        assert got.name == want.name
        # the same rays, in mmocap's y-up world turned from the file's z-up one
        np.testing.assert_allclose(got.project(points @ UP_AXES["+z"].T), want.project(points), atol=0.01)
    opened = RecordingDataset(str(recording_copy), offsets=OFFSETS, up="+y").open(progress=False)
    np.testing.assert_allclose(opened.cameras[0].project(points), cameras[0].project(points), atol=0.01)


def _break(root: Path, how: str) -> dict:
    """Break a copy of the recording; returns extra RecordingDataset arguments."""
    if how in FOLDER_BREAKS:
        FOLDER_BREAKS[how](root)
    elif how == "no-calibration":
        (root / "calibration.yml").unlink()
    elif how == "two-calibrations":
        shutil.copy(root / "calibration.yml", root / "calibration.yaml")
    elif how == "no-video":
        (root / "videos" / "C2.mp4").unlink()
        return {"cameras": ["C1", "C2"]}
    elif how == "video-and-images":
        (root / "images" / "C1").mkdir(parents=True)
    elif how == "damaged-video":
        (root / "videos" / "C1.mp4").write_bytes(b"\0" * 100)
    elif how == "background-past-the-end":
        return {"background": [0, 9]}
    elif how == "offset-of-an-unknown-camera":
        return {"offsets": {"C9": 1}}
    elif how == "offsets-past-the-end":
        return {"offsets": {"C1": 4}}
    elif how == "images-without-fps":
        for video in (root / "videos").glob("*.mp4"):
            folder = root / "images" / video.stem
            folder.mkdir(parents=True)
            for k in range(4):
                cv2.imwrite(str(folder / f"{k}.png"), np.zeros((240, 320, 3), np.uint8))
            video.unlink()
    elif how == "wrong-resolution":
        folder = root / "images" / "C1"
        folder.mkdir(parents=True)
        cv2.imwrite(str(folder / "0.png"), np.zeros((100, 100, 3), np.uint8))
        (root / "videos" / "C1.mp4").unlink()
        return {"fps": 60.0, "cameras": ["C1"]}
    return {}


CASES = {  # how -> words the one-line error must hold
    "no-calibration": ["no calibration in recording", "calibration.yml"],
    "two-calibrations": ["2 calibrations", "dataset.calibration"],
    "no-video": ["camera C2", "no video"],
    "video-and-images": ["camera C1", "keep one"],
    "damaged-video": ["C1.mp4"],
    "no-background": ["camera C1", "no background", "dataset.background"],
    "background-past-the-end": ["dataset.background ends at frame 9"],
    "offset-of-an-unknown-camera": ["dataset.offsets", "C9"],
    "offsets-past-the-end": ["camera C1", "offset 4", "none is left"],
    "images-without-fps": ["dataset.fps"],
    "wrong-resolution": ["camera C1", "100x100", "320x240"],
    "masks-of-one-camera": ["camera C2", "none of this one", "masks"],
    "masks-wrong-count": ["camera C1", "3 masks", "4 frames", "one mask per frame"],
    "masks-wrong-size": ["camera C1", "160x120", "320x240", "at the frames' size"],
    "beyond-the-codec-padding": ["camera C1", "320x240", "337x240"],
}


@pytest.mark.parametrize("how", list(CASES))
def test_a_broken_recording_is_one_clear_error(recording_copy, how):
    extra = {"offsets": OFFSETS, **_break(recording_copy, how)}
    with pytest.raises((DataError, ConfigError)) as caught:  # noqa: PT012 - at opening or at the first image
        opened = RecordingDataset(str(recording_copy), **extra).open(progress=False)
        opened.images(0)
        opened.background(opened.cameras[0])  # a recording without a plate opens, and says so when asked
    message = str(caught.value)
    assert "\n" not in message
    for word in CASES[how]:
        assert word in message, message


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("units", "cm"),
        ("up", "y"),
        ("start", -1),
        ("frames", 0),
        ("background", [3]),
        ("background", [4, 2]),
        ("fps", 0),
    ],
)
def test_a_bad_setting_names_its_key(recording, key, value):
    with pytest.raises(ConfigError, match=f"dataset.{key}"):
        RecordingDataset(str(recording), **{key: value})


def test_a_recording_without_a_plate_opens_and_given_masks_are_read_as_they_are(recording_copy):
    shutil.rmtree(recording_copy / "background")
    write_masks(recording_copy)
    first = recording_copy / "masks" / "C1" / "0000.png"
    person = np.zeros((240, 320), np.uint8)
    person[100:200, 150:180] = 255
    cv2.imwrite(str(first), person)
    opened = RecordingDataset(str(recording_copy), offsets=OFFSETS).open(progress=False)
    assert not opened.has_background
    assert opened.has_given_masks
    masks = opened.given_masks(0)
    assert [m.shape for m in masks] == [(240, 320)] * len(opened.cameras)
    np.testing.assert_array_equal(masks[0], person)
    assert not masks[1].any()


def test_a_video_short_of_its_calibration_by_the_codec_padding_is_read_with_a_warning(recording_copy):
    pad_calibration(recording_copy, CODEC_PADDING_PX)
    calibrated = read_calibration(recording_copy / "calibration.yml", units="mm").cameras[0]
    with pytest.warns(MmocapWarning, match=r"camera C1: .*C1.mp4 is 320x240, its calibration says 336x240.*padding"):
        opened = RecordingDataset(str(recording_copy), offsets=OFFSETS).open(progress=False)
    camera = opened.cameras[0]
    assert (camera.width, camera.height) == (320, 240)
    np.testing.assert_array_equal(camera.K, calibrated.K)  # the principal point kept
    assert opened.images(0)[0].shape[:2] == (240, 320)


def test_a_scale_shrinks_the_frames_and_the_cameras_together(recording):
    full = RecordingDataset(str(recording), offsets=OFFSETS).open(progress=False)
    half = RecordingDataset(str(recording), offsets=OFFSETS, scale=0.5).open(progress=False)
    points = np.array([[0.0, 900.0, 0.0], [250.0, 1500.0, -100.0]])
    for big, small, image in zip(full.cameras, half.cameras, half.images(1)):
        assert (small.width, small.height) == (160, 120)
        assert image.shape[:2] == (120, 160)
        np.testing.assert_allclose(small.project(points), (big.project(points) + 0.5) * 0.5 - 0.5, atol=1e-9)
    np.testing.assert_array_equal(half.markers(), full.markers())  # the world, in mm, is unchanged
    assert half.background(half.cameras[0])[0].shape[:2] == (120, 160)


def test_keypoints_follow_the_offsets_start_and_scale_of_the_frames(recording_copy):
    """Keypoint files numbered by each camera's video frames (C2's two early frames
    included) give, for the tracked frame k, the projections of that frame's points in the
    cameras as tracked: shrunk by the scale, started at ``start``."""
    full = RecordingDataset(str(recording_copy), offsets=OFFSETS).open(progress=False)
    assert not full.has_keypoints
    points = np.random.default_rng(4).uniform([-400, 100, -400], [400, 1800, 400], size=(full.n_frames, 17, 3))
    for camera, source, offset in zip(full.cameras, full.sources, full.offsets):
        for frame in range(source.count):
            synchronised = min(max(frame - offset, 0), full.n_frames - 1)
            uv = camera.project(points[synchronised])
            write_openpose_json(openpose_path(recording_copy, camera.name, frame), [np.c_[uv, np.full(17, 0.9)]])
    half = RecordingDataset(str(recording_copy), offsets=OFFSETS, scale=0.5, start=1, frames=2).open(progress=False)
    assert half.has_keypoints
    files = half.keypoint_files()
    assert (files.skeleton, files.n_frames, files.cameras) == ("COCO_17", 2, [c.name for c in half.cameras])
    for k in range(2):
        got = files.frame(k)
        for c, small in enumerate(half.cameras):
            np.testing.assert_allclose(got[c, :, :2], small.project(points[1 + k]), atol=1e-3)
            np.testing.assert_allclose(
                files.ideal_frame(k, half.cameras)[c, :, :2], small.ideal().project(points[1 + k]), atol=2e-3
            )
