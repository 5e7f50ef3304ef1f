"""HumanEva-I layout: a tiny synthetic sequence exported to it and read back, bad input, and
the pipeline run on the exported folder."""
import os
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
import scipy.io

from mmocap import config as mmocap_config
from mmocap.body.model import MARKER_NAMES, BodyModel
from mmocap.body.skeleton import dof_mask
from mmocap.camera import Camera
from mmocap.data import humaneva as he
from mmocap.data.sequence import Sequence
from mmocap.data.synthetic import generate
from mmocap.errors import ConfigError, DataError
from mmocap.stages.evaluation import marker_error

CAMERAS = ["C1", "BW1"]
FRAMES = 3
LEAD = 4  # the exporter's default mocap lead
LEAD_IN = he.TOOLBOX_FIRST_FRAME - 1  # images before the sequence in an exported video
FIRST = LEAD + 2 * LEAD_IN  # 0-based mocap frame of the sequence's first frame


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory) -> Path:
    return generate(tmp_path_factory.mktemp("synthetic") / "S1_walking", frames=FRAMES, cameras=CAMERAS,
                    width=96, height=72, background_frames=3, seed=3, progress=False)


@pytest.fixture(scope="module")
def exported(synthetic, tmp_path_factory) -> Path:
    return he.export(synthetic, tmp_path_factory.mktemp("humaneva"), progress=False)


@pytest.fixture
def damaged(exported, tmp_path) -> Path:
    """A private copy of the exported folder that a test may damage."""
    return Path(shutil.copytree(exported, tmp_path / "HumanEva"))


def open_he(root, **kwargs):
    return he.HumanEvaDataset(root, cameras=kwargs.pop("cameras", CAMERAS), **kwargs).open(progress=False)


def test_exported_layout_has_the_real_names(exported):
    for path in ("S1/Calibration_Data/C1.cal", "S1/Calibration_Data/BW1.cal",
                 "S1/Image_Data/Walking_1_(C1).avi", "S1/Image_Data/Walking_1_(BW1).avi",
                 "S1/Sync_Data/Walking_1_(C1).ofs", "S1/Mocap_Data/Walking_1.mat",
                 "Background/Background_1_(C1).avi", "Background/Background_1_(BW1).avi"):
        assert (exported / path).is_file(), path


def test_calibration_round_trip(synthetic, exported):
    seq = open_he(exported)
    points = np.random.default_rng(0).uniform([-800, 0, -800], [800, 1900, 800], size=(100, 3))
    for cam in seq.cameras:
        original = Camera.load(synthetic / "calibration" / f"{cam.name}.json")
        np.testing.assert_allclose(cam.project(points), original.project(points), atol=1e-9)
        assert (cam.width, cam.height, cam.colour) == (96, 72, cam.name == "C1")


def test_sync_offsets_arithmetic(tmp_path):
    sync = he.SyncOffsets(image_start=3, mocap_start=10, mocap_scale=2.0)
    np.testing.assert_allclose(sync.mocap_index([3, 4, 10]), [10, 12, 24])
    np.testing.assert_allclose(sync.image_index(sync.mocap_index([1.0, 7.5])), [1.0, 7.5])
    sync.save(tmp_path / "a.ofs")
    assert he.SyncOffsets.load(tmp_path / "a.ofs") == sync
    # markers at fractional mocap indices are interpolated between neighbours
    mocap = np.arange(5, dtype=float)[:, None, None] * np.ones((1, 2, 3))
    mocap[3, 1] = np.nan
    out = he.sample_mocap(mocap, [1.0, 2.5, 4.0, 5.0, 5.5, 0.5])
    np.testing.assert_allclose(out[:4, 0, 0], [0.0, 1.5, 3.0, 4.0])
    assert np.isnan(out[2, 1]).all() and not np.isnan(out[1, 1]).any()   # row 3 is missing
    assert np.isnan(out[4:]).all()                                          # outside the recording


def test_other_cameras_follow_their_own_ofs(synthetic, damaged):
    """BW1 starting one image later: sequence frame k shows its image k + 2 + LEAD_IN (1-based)."""
    he.SyncOffsets(2, 1 + LEAD, 2.0).save(damaged / "S1/Sync_Data/Walking_1_(BW1).ofs")
    seq = open_he(damaged)
    assert seq.image_index.tolist() == [[6, 7], [7, 8]] and seq.n_frames == 2
    original = Sequence.open(synthetic)
    np.testing.assert_array_equal(seq.images(0)[1], original.images(1)[1])
    np.testing.assert_array_equal(seq.images(1)[0], original.images(1)[0])


@pytest.mark.parametrize("images", ["avi", "png"])
def test_images_background_and_markers_round_trip(synthetic, tmp_path, images):
    root = he.export(synthetic, tmp_path / "he", images=images, progress=False)
    seq = open_he(root)
    original = Sequence.open(synthetic)
    # the sequence after the lead-in copies, at the toolbox's first frame (image 6)
    assert seq.n_frames == FRAMES and seq.subject == "S1" and seq.meta["first_image"] == 6
    for f in range(FRAMES):
        for mine, theirs in zip(seq.images(f), original.images(f)):
            np.testing.assert_array_equal(mine, theirs)  # lossless video
    for cam, cam0 in zip(seq.cameras, original.cameras):
        np.testing.assert_array_equal(np.stack(seq.background(cam)), np.stack(original.background(cam0)))
    np.testing.assert_allclose(seq.markers(), original.markers(), atol=1e-9)


def test_mocap_file_has_the_real_structure(synthetic, exported):
    mat = scipy.io.loadmat(str(exported / "S1/Mocap_Data/Walking_1.mat"))
    groups = mat["ParameterGroup"]
    point = groups[0, [str(g[0, 0][0]) for g in groups[0]["name"]].index("POINT")]
    params = point["Parameter"]
    names = [str(p[0, 0][0]) for p in params[0]["name"]]
    labels = [str(x[0]) for x in params[0, names.index("LABELS")]["data"][0]]
    rate = float(np.squeeze(params[0, names.index("RATE")]["data"]))
    assert {"LFHD", "C7", "LSHO", "RANK"} <= set(labels) and rate == 120.0
    # 120 Hz: the lead, stored as zeros (missing), the first frame held over the lead-in
    # images, then (frames - 1) * 2 + 1 samples
    assert mat["Markers"].shape == (FIRST + 2 * (FRAMES - 1) + 1, len(labels), 3)
    assert np.all(mat["Markers"][:LEAD] == 0)
    held = mat["Markers"][LEAD:FIRST + 1]
    np.testing.assert_array_equal(held, np.repeat(mat["Markers"][FIRST:FIRST + 1], 2 * LEAD_IN + 1, axis=0))
    truth = Sequence.open(synthetic).markers()
    ankle = labels.index("RANK")
    np.testing.assert_allclose(mat["Markers"][FIRST + 1, ankle], truth[:2, MARKER_NAMES.index("r_ankle")].mean(0))


def test_missing_markers_are_nan_and_the_start_skips_them(damaged):
    path = damaged / "S1/Mocap_Data/Walking_1.mat"
    labels, markers = he.read_mocap(path)
    assert np.isnan(markers[:LEAD]).all() and not np.isnan(markers[LEAD:]).any()
    markers[FIRST, labels.index("LKNE")] = np.nan   # image 6: the left knee marker drops out
    markers[FIRST + 4, labels.index("C7")] = np.nan  # image 8: the neck marker
    he.write_mocap(path, labels, markers)
    seq = open_he(damaged)
    # the sequence starts at image 7, the first with every marker from the toolbox's first frame on
    assert seq.meta["first_image"] == 7 and seq.n_frames == 2
    truth = seq.markers()
    neck = MARKER_NAMES.index("neck")
    assert np.isnan(truth[1, neck]).all() and not np.isnan(np.delete(truth, neck, axis=1)).any()
    assert not np.isnan(truth[0]).any()
    with pytest.raises(DataError, match="markers neck are missing at the first frame"):
        open_he(damaged, start_frame=8)


def test_x0_is_fitted_to_the_first_frame_markers(synthetic, exported, tmp_path):
    seq = open_he(exported)
    body = BodyModel("S1", vertices=None)
    truth = Sequence.open(synthetic)
    fitted = marker_error(body.markers(seq.x0[None]), truth.markers()[:1])[0]
    true_pose = marker_error(body.markers(truth.x0[None]), truth.markers()[:1])[0]
    assert fitted < true_pose + 2.0 and fitted < 10.0
    assert np.all(seq.x0[~dof_mask(39)] == 0)
    # a user-given x0 is taken as it is
    np.savetxt(tmp_path / "x0.txt", truth.x0)
    np.testing.assert_allclose(open_he(exported, x0=str(tmp_path / "x0.txt")).x0, truth.x0)
    (tmp_path / "bad.txt").write_text("1 2 3")
    with pytest.raises(DataError, match="bad.txt must hold 51"):
        open_he(exported, x0=str(tmp_path / "bad.txt"))


def test_fit_pose_recovers_a_turned_pose():
    """A pose turned about the vertical and bent is found from its markers alone."""
    body = BodyModel("S1", vertices=None)
    mask = dof_mask(39)
    x = np.zeros(51)
    x[:3] = (300.0, 950.0, -200.0)
    x[4] = 2.5                                  # root turned about y
    x[3 + 3 * 11] = 0.6                         # left knee flexed
    x[3 + 3 * 4 + 1] = 1.0                      # left elbow flexed
    fitted = he.fit_pose(body, body.markers(x[None])[0], mask)
    assert marker_error(body.markers(fitted[None]), body.markers(x[None]))[0] < 5.0


@pytest.mark.parametrize("damage, message", [
    (lambda r: (r / "S1/Calibration_Data/C1.cal").write_text("600 610 320\n240 0 0"), r"C1.cal holds 6 numbers"),
    (lambda r: (r / "S1/Calibration_Data/BW1.cal").write_text("x " * 22), r"BW1.cal: non-numeric"),
    (lambda r: he.SyncOffsets(50, 1, 2).save(r / "S1/Sync_Data/Walking_1_(C1).ofs"),
     r"Walking_1_\(C1\).ofs starts at image 50, past the end of .*Walking_1_\(C1\).avi \(8 images\)"),
    (lambda r: he.SyncOffsets(-40, 1, 2).save(r / "S1/Sync_Data/Walking_1_(BW1).ofs"),
     r"Walking_1_\(BW1\).ofs: no image of .* falls within"),
    (lambda r: (r / "S1/Sync_Data/Walking_1_(C1).ofs").write_text("1 2"), r"\(C1\).ofs must hold 3"),
    (lambda r: (r / "S1/Image_Data/Walking_1_(BW1).avi").unlink(),
     r"camera BW1: image data not found: .*Walking_1_\(BW1\).avi"),
    (lambda r: shutil.rmtree(r / "S1/Calibration_Data"), r"calibration file not found: .*C1.cal"),
    (lambda r: (r / "S1/Image_Data/Walking_1_(C1).avi").write_bytes(b"RIFF not a video" * 8),
     r"camera C1: cannot read video .*Walking_1_\(C1\).avi"),
    (lambda r: (r / "Background/Background_1_(BW1).avi").unlink(), r"camera BW1: no background video"),
    (lambda r: (r / "S1/Mocap_Data/Walking_1.mat").write_bytes(b"garbage"), r"cannot read mocap file .*Walking_1.mat"),
    (lambda r: shutil.rmtree(r / "S1"), r"subject folder not found"),
])
def test_bad_input_names_the_file(damaged, damage, message):
    damage(damaged)
    with pytest.raises(DataError, match=message):
        open_he(damaged)


def test_background_too_short(damaged):
    with pytest.raises(DataError, match=r"camera C1: background .*Background_1_\(C1\).avi holds 3 frames.*at least 5"):
        open_he(damaged, min_background_frames=5, background_frames=10)


def test_mocap_without_a_mapped_label(damaged):
    path = damaged / "S1/Mocap_Data/Walking_1.mat"
    labels, markers = he.read_mocap(path)
    labels[labels.index("LELB")] = "LELX"
    he.write_mocap(path, labels, markers)
    with pytest.raises(DataError, match=r"Walking_1.mat has no marker labelled LELB \(mapped to 'l_elbow'"):
        open_he(damaged)


def test_a_trial_without_mocap_opens_without_a_first_pose_or_takes_the_one_given(damaged, synthetic, tmp_path):
    (damaged / "S1/Mocap_Data/Walking_1.mat").unlink()
    found = open_he(damaged)  # the automatic start finds the first pose
    assert found.x0 is None and found.n_frames == FRAMES and np.isnan(found.markers()).all()
    np.savetxt(tmp_path / "x0.txt", Sequence.open(synthetic).x0)
    seq = open_he(damaged, x0=str(tmp_path / "x0.txt"))
    assert seq.n_frames == FRAMES and np.isnan(seq.markers()).all()


@pytest.mark.parametrize("kwargs, message", [
    (dict(subject="S7"), "unknown HumanEva-I subject 'S7'"),
    (dict(action="Dancing"), "unknown HumanEva-I action 'Dancing'"),
    (dict(trial=4), "unknown HumanEva-I trial 4"),
    (dict(cameras=["C9"]), "dataset.cameras must name HumanEva-I cameras"),
    (dict(root=None), "dataset.root must be set"),
    (dict(marker_map={"head": ["LFHD"]}), "marker_map must give labels"),
    (dict(marker_map={**he.default_marker_map(), "neck": ["LFHD"]}), "label for two markers"),
    (dict(split="val"), r"^dataset.split must be null or one of train, validation, test, got 'val'$"),
    (dict(split="validation", trial=2), r"^dataset.split 'validation' has no frames of S1 Walking_2: the HumanEva-I "
                                        r"toolbox's partitions of its video are test; set dataset.split to one of "
                                        r"them or to null$"),
    (dict(split="train", subject="S4"), r"^dataset.split 'train' has no frames of S4 Walking_1: .* are none; "),
    (dict(split="train", action="Combo"), r"^dataset.split 'train' has no frames of S1 Combo_1: "),
])
def test_bad_config_values(exported, kwargs, message):
    args = dict(root=exported, cameras=CAMERAS) | kwargs
    with pytest.raises(ConfigError, match=message):
        he.HumanEvaDataset(**args)


# --- the toolbox's frames and partitions ---------------------------------------------------

LONG = 1212  # images per camera: to the end of S1 Walking_1's Train partition in the layout below


@pytest.fixture(scope="module")
def long_layout(exported, tmp_path_factory) -> Path:
    """The exported folder with LONG images per camera (one image, hard-linked), every marker
    present at every mocap frame, and mocap frame 1 at C1's image 10 and BW1's image 9, as in
    the dataset, whose mocap starts after its videos: toolbox frame F is C1's image F + 9."""
    root = Path(shutil.copytree(exported, tmp_path_factory.mktemp("long") / "HumanEva"))
    for cam, image_start in (("C1", 10), ("BW1", 9)):
        video = root / f"S1/Image_Data/Walking_1_({cam}).avi"
        image = he.FrameSource(video, cam, he.is_colour(cam)).read(1)
        video.unlink()
        folder = video.with_suffix("")
        folder.mkdir()
        cv2.imwrite(str(folder / "000001.png"), image)
        for k in range(2, LONG + 1):
            os.link(folder / "000001.png", folder / f"{k:06d}.png")
        he.SyncOffsets(image_start, 1, 2.0).save(root / f"S1/Sync_Data/Walking_1_({cam}).ofs")
    path = root / "S1/Mocap_Data/Walking_1.mat"
    labels, markers = he.read_mocap(path)
    he.write_mocap(path, labels, np.repeat(markers[FIRST:FIRST + 1], 2 * LONG, axis=0))
    return root


def test_toolbox_frame_numbering():
    # mocap starting after the videos: toolbox frame 1 is mocap frame 1
    assert he.toolbox_frame_offsets([he.SyncOffsets(10, 1, 2.0), he.SyncOffsets(9, 1, 2.0)]).tolist() == [10, 9]
    # mocap starting first: toolbox frame 1 is the earliest camera's first image
    assert he.toolbox_frame_offsets([he.SyncOffsets(2, 5, 2.0), he.SyncOffsets(1, 5, 2.0)]).tolist() == [2, 1]
    # the second camera's image 1 at mocap 6: the first's image 2.5 at that time, rounded up as in MATLAB
    assert he.toolbox_frame_offsets([he.SyncOffsets(2, 5, 2.0), he.SyncOffsets(1, 6, 2.0)]).tolist() == [3, 1]


def test_the_default_start_is_not_before_the_toolbox_first_frame(long_layout):
    """Every marker is present from toolbox frame 1 (C1's image 10) on; the toolbox starts at its frame 6."""
    seq = open_he(long_layout, frames=2)
    assert seq.image_index.tolist() == [[15, 14], [16, 15]] and seq.meta["first_image"] == 15


@pytest.mark.parametrize("split, first, last", [("validation", 6, 590), ("train", 591, 1203)])
def test_a_split_selects_exactly_the_toolbox_range(long_layout, split, first, last):
    seq = open_he(long_layout, split=split)
    np.testing.assert_array_equal(seq.image_index, np.arange(first, last + 1)[:, None] + [9, 8])
    assert seq.meta["split"] == split and not np.isnan(seq.markers()).any()
    later = open_he(long_layout, split=split, start_frame=first + 9 + 100)  # C1's image of toolbox frame first + 100
    assert later.image_index[0, 0] == first + 109 and later.image_index[-1, 0] == last + 9


@pytest.mark.parametrize("start_frame", [14, 600])
def test_a_start_frame_outside_the_split_is_refused(long_layout, start_frame):
    with pytest.raises(ConfigError, match=rf"^dataset.start_frame {start_frame} is outside dataset.split 'validation' "
                                          r"of S1 Walking_1, images 15..599 of C1; give a start_frame in that range, "
                                          r"or null$"):
        open_he(long_layout, split="validation", start_frame=start_frame)


def test_a_split_past_the_end_of_the_videos(exported):
    with pytest.raises(DataError, match=r"dataset.split 'validation' is images 6..590 of .*Walking_1_\(C1\).avi "
                                        r"\(toolbox frames 6..590\), not all of them in every camera's video"):
        open_he(exported, split="validation")


def test_pipeline_runs_on_the_exported_folder(exported, tmp_path):
    from mmocap.pipeline import run

    cfg = mmocap_config.compose([
        "dataset=humaneva", f"dataset.root={exported}", "dataset.subject=S1", "dataset.action=Walking",
        "dataset.trial=1", f"dataset.cameras=[{','.join(CAMERAS)}]", "tracking.frames=2",
        "tracking.evaluations=200", "progress=false", "overlays=1", "body.vertices=2000"])
    summary = run(cfg, tmp_path / "run")
    assert summary["frames"] == 2 and summary["subject"] == "S1" and summary["action"] == "Walking"
    assert summary["cameras"] == CAMERAS
    assert np.isfinite(summary["mean_marker_error_mm"]) and summary["mean_marker_error_mm"] < 60
    assert (tmp_path / "run" / "summary.json").is_file()


def test_export_command(synthetic, tmp_path):
    def mmocap(*args):
        from tests.helpers import mmocap as run

        return run("export-humaneva", *args, cwd=tmp_path, timeout=120)

    out = mmocap(synthetic, tmp_path / "he", "--images", "png", "--trial", "3")
    assert out.returncode == 0, out.stderr
    assert len(list((tmp_path / "he/S1/Image_Data/Walking_3_(BW1)").glob("*.png"))) == LEAD_IN + FRAMES
    bad = mmocap(tmp_path / "nothing", tmp_path / "he2")
    assert bad.returncode == 2 and "not a sequence folder" in bad.stderr and "Traceback" not in bad.stderr


def image_folder(tmp_path, images, names=None):
    folder = tmp_path / "Walking_1_(C1)"
    folder.mkdir()
    for k, image in enumerate(images):
        cv2.imwrite(str(folder / (names[k] if names else f"{k + 1:06d}.png")), image)
    return folder


def test_image_folders_of_a_greyscale_camera_may_hold_colour_frames(tmp_path):
    """As HumanEva-I's greyscale videos are stored in colour, a greyscale camera's
    3-channel frames are converted; 1-channel frames are taken as they are."""
    grey = np.arange(12 * 16, dtype=np.uint8).reshape(12, 16)
    source = he.FrameSource(image_folder(tmp_path, [cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR), grey]), "BW1", False)
    np.testing.assert_array_equal(source.read(1), grey)
    np.testing.assert_array_equal(source.read(2), grey)


def test_a_greyscale_frame_in_a_colour_camera_is_refused(tmp_path):
    colour = np.zeros((12, 16, 3), np.uint8)
    source = he.FrameSource(image_folder(tmp_path, [colour, colour[..., 0]]), "C1", True)
    with pytest.raises(DataError, match=r"camera C1: .*000002.png is greyscale, but C1 is a colour camera"):
        source.read(2)


@pytest.mark.parametrize("images, message", [
    ([np.zeros((12, 16, 3), np.uint8), np.zeros((10, 16, 3), np.uint8)], r"000002.png is 16x10, its first image 16x12"),
    ([np.zeros((12, 16, 4), np.uint8)], "has 4 channels of uint8"),
    ([np.zeros((12, 16, 3), np.uint16)], "has 3 channels of uint16"),
])
def test_bad_frames_in_an_image_folder_name_camera_and_file(tmp_path, images, message):
    folder = image_folder(tmp_path, images)
    with pytest.raises(DataError, match=f"camera C1: .*{message}"):
        he.FrameSource(folder, "C1", True).read(len(images))


@pytest.mark.parametrize("names, message", [
    (["000001.png", "000002.png", "000004.png"], r"not numbered consecutively \(missing: 3, repeated: none\)"),
    (["000001.png", "000001.jpg", "000002.png"], r"not numbered consecutively \(missing: none, repeated: 1\)"),
    (["000001.png", "first.png"], "without a frame number: first.png"),
])
def test_a_gap_in_the_image_numbers_is_refused(tmp_path, names, message):
    folder = image_folder(tmp_path, [np.zeros((12, 16, 3), np.uint8)] * len(names), names)
    with pytest.raises(DataError, match=f"camera C1: .*{message}"):
        he.FrameSource(folder, "C1", True)


def test_an_xvid_video_with_b_frames_gives_every_image_in_any_order(tmp_path):
    """HumanEva-I's videos are XviD (MPEG-4 part 2) with B-frames, in which a seek may
    land on another frame; the images come out as a decode from the start gives them,
    whatever the order they are asked in."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    base = np.random.default_rng(0).integers(0, 256, (48, 64, 3), dtype=np.uint8)
    frames = [np.ascontiguousarray(np.roll(base, 3 * k, axis=1)) for k in range(30)]
    path = tmp_path / "Walking_1_(C1).avi"
    writer = imageio_ffmpeg.write_frames(str(path), (64, 48), fps=60, codec="mpeg4", pix_fmt_in="bgr24",
                                         output_params=["-bf", "2", "-g", "12", "-vtag", "XVID", "-q:v", "3"],
                                         macro_block_size=1)
    writer.send(None)
    for frame in frames:
        writer.send(frame)
    writer.close()
    capture, decoded = cv2.VideoCapture(str(path)), []
    while (image := capture.read()[1]) is not None:
        decoded.append(image)
    capture.release()
    assert len(decoded) == 30
    nearest = [int(np.argmin([np.abs(d.astype(int) - f).mean() for f in frames])) for d in decoded]
    assert nearest == list(range(30))  # the video holds every frame, in order
    source = he.FrameSource(path, "C1", True)
    for index in (6, 18, 4, 30, 12, 26, 9, 1, 30):
        np.testing.assert_array_equal(source.read(index), decoded[index - 1])


def test_a_damaged_frame_names_camera_and_file(tmp_path):
    folder = image_folder(tmp_path, [np.zeros((12, 16, 3), np.uint8)] * 2)
    (folder / "000002.png").write_bytes(b"\x89PNG\r\n\x1a\n damaged")
    with pytest.raises(DataError, match=r"camera C1: cannot read .*000002.png"):
        he.FrameSource(folder, "C1", True).read(2)


@pytest.mark.parametrize("index, value, message", [
    (0, -600.0, "'fc, cc, alpha_c' focal lengths fx = -600"),
    (2, 5000.0, "'fc, cc, alpha_c' principal point cx = 5000"),
    (11, 0.5, "'R' is not a rotation"),  # R[0, 1]: a shear with det 1
])
def test_cal_values_are_checked_like_every_calibration(damaged, index, value, message):
    path = damaged / "S1/Calibration_Data/BW1.cal"
    numbers = path.read_text().split()
    numbers[index] = repr(value)
    if index == 11:
        numbers[10:19] = ["1", "0.5", "0", "0", "1", "0", "0", "0", "1"]
    path.write_text("\n".join(numbers))
    with pytest.raises(DataError, match=rf"camera BW1: .*BW1.cal: {message}"):
        open_he(damaged)


def test_a_trial_without_mocap_has_no_ground_truth_to_score(damaged, synthetic, tmp_path):
    (damaged / "S1/Mocap_Data/Walking_1.mat").unlink()
    np.savetxt(tmp_path / "x0.txt", Sequence.open(synthetic).x0)
    seq = open_he(damaged, x0=str(tmp_path / "x0.txt"))
    with pytest.raises(DataError, match=r"Walking_1.mat: none of the 3 tracked frames has ground-truth markers"):
        seq.ground_truth(3, "stop")
