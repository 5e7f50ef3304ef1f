"""One trial opened for tracking: cameras, timing, ground truth, the first pose, the toolbox's
partitions, bad input, and the pipeline run on the exported folder."""

import os
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mmocap import config as mmocap_config
from mmocap.body.model import MARKER_NAMES, BodyModel
from mmocap.body.skeleton import dof_mask
from mmocap.camera import Camera
from mmocap.data.humaneva.dataset import HumanEvaDataset, read_pose_file
from mmocap.data.humaneva.frames import FrameSource
from mmocap.data.humaneva.layout import is_colour
from mmocap.data.humaneva.mocap import default_marker_map, read_mocap, write_mocap
from mmocap.data.humaneva.synchronisation import SyncOffsets
from mmocap.data.sequence import Sequence
from mmocap.errors import ConfigError, DataError
from mmocap.stages.accuracy import marker_error
from tests.helpers import HE_CAMERAS, HE_FIRST, HE_FRAMES, HE_LEAD, damages, open_he, read_damaged


def test_calibration_round_trip(synthetic, exported):
    seq = open_he(exported)
    points = np.random.default_rng(0).uniform([-800, 0, -800], [800, 1900, 800], size=(100, 3))
    for cam in seq.cameras:
        original = Camera.load(synthetic / "calibration" / f"{cam.name}.json")
        np.testing.assert_allclose(cam.project(points), original.project(points), atol=1e-9)
        assert (cam.width, cam.height, cam.colour) == (96, 72, cam.name == "C1")


def test_other_cameras_follow_their_own_ofs(synthetic, damaged):
    """BW1 starting one image later: sequence frame k shows its image k + 2 + LEAD_IN (1-based)."""
    SyncOffsets(2, 1 + HE_LEAD, 2.0).save(damaged / "S1/Sync_Data/Walking_1_(BW1).ofs")
    seq = open_he(damaged)
    assert seq.image_index.tolist() == [[6, 7], [7, 8]]
    assert seq.n_frames == 2
    original = Sequence.open(synthetic)
    np.testing.assert_array_equal(seq.images(0)[1], original.images(1)[1])
    np.testing.assert_array_equal(seq.images(1)[0], original.images(1)[0])


def test_missing_markers_are_nan_and_the_start_skips_them(damaged):
    path = damaged / "S1/Mocap_Data/Walking_1.mat"
    labels, markers = read_mocap(path)
    assert np.isnan(markers[:HE_LEAD]).all()
    assert not np.isnan(markers[HE_LEAD:]).any()
    markers[HE_FIRST, labels.index("LKNE")] = np.nan  # image 6: the left knee marker drops out
    markers[HE_FIRST + 4, labels.index("C7")] = np.nan  # image 8: the neck marker
    write_mocap(path, labels, markers)
    seq = open_he(damaged)
    # the sequence starts at image 7, the first with every marker from the toolbox's first frame on
    assert seq.meta["first_image"] == 7
    assert seq.n_frames == 2
    truth = seq.markers()
    neck = MARKER_NAMES.index("neck")
    assert np.isnan(truth[1, neck]).all()
    assert not np.isnan(np.delete(truth, neck, axis=1)).any()
    assert not np.isnan(truth[0]).any()
    with pytest.raises(DataError, match="markers neck are missing at the first frame"):
        open_he(damaged, start_frame=8)


def test_x0_is_fitted_to_the_first_frame_markers(synthetic, exported, tmp_path):
    seq = open_he(exported)
    body = BodyModel("S1", vertices=None)
    truth = Sequence.open(synthetic)
    fitted = marker_error(body.markers(seq.x0[None]), truth.markers()[:1])[0]
    true_pose = marker_error(body.markers(truth.x0[None]), truth.markers()[:1])[0]
    assert fitted < true_pose + 2.0
    assert fitted < 10.0
    assert np.all(seq.x0[~dof_mask(39)] == 0)
    # a user-given x0 is taken as it is
    np.savetxt(tmp_path / "x0.txt", truth.x0)
    np.testing.assert_allclose(open_he(exported, x0=str(tmp_path / "x0.txt")).x0, truth.x0)
    (tmp_path / "bad.txt").write_text("1 2 3\n")
    with pytest.raises(DataError, match="bad.txt must hold 51"):
        open_he(exported, x0=str(tmp_path / "bad.txt"))


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda r: (r / "S1/Calibration_Data/C1.cal").write_text("600 610 320\n240 0 0\n"), r"C1.cal holds 6 numbers"),
        (lambda r: (r / "S1/Calibration_Data/BW1.cal").write_text("x " * 22 + "\n"), r"BW1.cal: non-numeric"),
        (
            lambda r: SyncOffsets(50, 1, 2).save(r / "S1/Sync_Data/Walking_1_(C1).ofs"),
            r"Walking_1_\(C1\).ofs starts at image 50, past the end of .*Walking_1_\(C1\).avi \(8 images\)",
        ),
        (
            lambda r: SyncOffsets(-40, 1, 2).save(r / "S1/Sync_Data/Walking_1_(BW1).ofs"),
            r"Walking_1_\(BW1\).ofs: no image of .* falls within",
        ),
        (lambda r: (r / "S1/Sync_Data/Walking_1_(C1).ofs").write_text("1 2\n"), r"\(C1\).ofs must hold 3"),
        (
            lambda r: (r / "S1/Image_Data/Walking_1_(BW1).avi").unlink(),
            r"camera BW1: image data not found: .*Walking_1_\(BW1\).avi",
        ),
        (lambda r: shutil.rmtree(r / "S1/Calibration_Data"), r"calibration file not found: .*C1.cal"),
        (
            lambda r: (r / "S1/Image_Data/Walking_1_(C1).avi").write_bytes(b"RIFF not a video" * 8),
            r"camera C1: cannot read video .*Walking_1_\(C1\).avi",
        ),
        (lambda r: (r / "Background/Background_1_(BW1).avi").unlink(), r"camera BW1: no background video"),
        (
            lambda r: (r / "S1/Mocap_Data/Walking_1.mat").write_bytes(b"garbage"),
            r"cannot read mocap file .*Walking_1.mat",
        ),
        (lambda r: shutil.rmtree(r / "S1"), r"subject folder not found"),
    ],
)
def test_bad_input_names_the_file(damaged, damage, message):
    damage(damaged)
    with pytest.raises(DataError, match=message):
        open_he(damaged)


def test_background_too_short(damaged):
    with pytest.raises(DataError, match=r"camera C1: background .*Background_1_\(C1\).avi holds 3 frames.*at least 5"):
        open_he(damaged, min_background_frames=5, background_frames=10)


def test_a_trial_without_mocap_opens_without_a_first_pose_or_takes_the_one_given(damaged, synthetic, tmp_path):
    (damaged / "S1/Mocap_Data/Walking_1.mat").unlink()
    found = open_he(damaged)  # the automatic start finds the first pose
    assert found.x0 is None
    assert found.n_frames == HE_FRAMES
    assert np.isnan(found.markers()).all()
    np.savetxt(tmp_path / "x0.txt", Sequence.open(synthetic).x0)
    seq = open_he(damaged, x0=str(tmp_path / "x0.txt"))
    assert seq.n_frames == HE_FRAMES
    assert np.isnan(seq.markers()).all()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(subject="S7"), "unknown HumanEva-I subject 'S7'"),
        (dict(action="Dancing"), "unknown HumanEva-I action 'Dancing'"),
        (dict(trial=4), "unknown HumanEva-I trial 4"),
        (dict(cameras=["C9"]), "dataset.cameras must name HumanEva-I cameras"),
        (dict(root=None), "dataset.root must be set"),
        (dict(marker_map={"head": ["LFHD"]}), "marker_map must give labels"),
        (dict(marker_map={**default_marker_map(), "neck": ["LFHD"]}), "label for two markers"),
        (dict(split="val"), r"^dataset.split must be null or one of train, validation, test, got 'val'$"),
        (
            dict(split="validation", trial=2),
            r"^dataset.split 'validation' has no frames of S1 Walking_2: the HumanEva-I "
            r"toolbox's partitions of its video are test; set dataset.split to one of "
            r"them or to null$",
        ),
        (dict(split="train", subject="S4"), r"^dataset.split 'train' has no frames of S4 Walking_1: .* are none; "),
        (dict(split="train", action="Combo"), r"^dataset.split 'train' has no frames of S1 Combo_1: "),
    ],
)
def test_bad_config_values(exported, kwargs, message):
    args = dict(root=exported, cameras=HE_CAMERAS) | kwargs
    with pytest.raises(ConfigError, match=message):
        HumanEvaDataset(**args)


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
        image = FrameSource(video, cam, is_colour(cam)).read(1)
        video.unlink()
        folder = video.with_suffix("")
        folder.mkdir()
        cv2.imwrite(str(folder / "000001.png"), image)
        for k in range(2, LONG + 1):
            os.link(folder / "000001.png", folder / f"{k:06d}.png")
        SyncOffsets(image_start, 1, 2.0).save(root / f"S1/Sync_Data/Walking_1_({cam}).ofs")
    path = root / "S1/Mocap_Data/Walking_1.mat"
    labels, markers = read_mocap(path)
    write_mocap(path, labels, np.repeat(markers[HE_FIRST : HE_FIRST + 1], 2 * LONG, axis=0))
    return root


def test_the_default_start_is_not_before_the_toolbox_first_frame(long_layout):
    """Every marker is present from toolbox frame 1 (C1's image 10) on; the toolbox starts at its frame 6."""
    seq = open_he(long_layout, frames=2)
    assert seq.image_index.tolist() == [[15, 14], [16, 15]]
    assert seq.meta["first_image"] == 15


@pytest.mark.parametrize(("split", "first", "last"), [("validation", 6, 590), ("train", 591, 1203)])
def test_a_split_selects_exactly_the_toolbox_range(long_layout, split, first, last):
    seq = open_he(long_layout, split=split)
    np.testing.assert_array_equal(seq.image_index, np.arange(first, last + 1)[:, None] + [9, 8])
    assert seq.meta["split"] == split
    assert not np.isnan(seq.markers()).any()
    later = open_he(long_layout, split=split, start_frame=first + 9 + 100)  # C1's image of toolbox frame first + 100
    assert later.image_index[0, 0] == first + 109
    assert later.image_index[-1, 0] == last + 9


@pytest.mark.parametrize("start_frame", [14, 600])
def test_a_start_frame_outside_the_split_is_refused(long_layout, start_frame):
    with pytest.raises(
        ConfigError,
        match=rf"^dataset.start_frame {start_frame} is outside dataset.split 'validation' "
        r"of S1 Walking_1, images 15..599 of C1; give a start_frame in that range, "
        r"or null$",
    ):
        open_he(long_layout, split="validation", start_frame=start_frame)


def test_a_split_past_the_end_of_the_videos(exported):
    with pytest.raises(
        DataError,
        match=r"dataset.split 'validation' is images 6..590 of .*Walking_1_\(C1\).avi "
        r"\(toolbox frames 6..590\), not all of them in every camera's video",
    ):
        open_he(exported, split="validation")


def test_pipeline_runs_on_the_exported_folder(exported, tmp_path):
    from mmocap.pipeline import run

    cfg = mmocap_config.compose(
        [
            "dataset=humaneva",
            f"dataset.root={exported}",
            "dataset.subject=S1",
            "dataset.action=Walking",
            "dataset.trial=1",
            f"dataset.cameras=[{','.join(HE_CAMERAS)}]",
            "tracking.frames=2",
            "tracking.evaluations=200",
            "progress=false",
            "overlays=1",
            "body.vertices=2000",
        ]
    )
    summary = run(cfg, tmp_path / "run")
    assert summary["frames"] == 2
    assert summary["subject"] == "S1"
    assert summary["action"] == "Walking"
    assert summary["cameras"] == HE_CAMERAS
    assert np.isfinite(summary["mean_marker_error_mm"])
    assert summary["mean_marker_error_mm"] < 60
    assert (tmp_path / "run" / "summary.json").is_file()


@pytest.mark.parametrize(
    ("index", "value", "message"),
    [
        (0, -600.0, "'fc, cc, alpha_c' focal lengths fx = -600"),
        (2, 5000.0, "'fc, cc, alpha_c' principal point cx = 5000"),
        (11, 0.5, "'R' is not a rotation"),  # R[0, 1]: a shear with det 1
    ],
)
def test_cal_values_are_checked_like_every_calibration(damaged, index, value, message):
    path = damaged / "S1/Calibration_Data/BW1.cal"
    numbers = path.read_text().split()
    numbers[index] = repr(value)
    if index == 11:
        numbers[10:19] = ["1", "0.5", "0", "0", "1", "0", "0", "0", "1"]
    path.write_text("\n".join(numbers) + "\n")
    with pytest.raises(DataError, match=rf"camera BW1: .*BW1.cal: {message}"):
        open_he(damaged)


def test_a_trial_without_mocap_has_no_ground_truth_to_score(damaged, synthetic, tmp_path):
    (damaged / "S1/Mocap_Data/Walking_1.mat").unlink()
    np.savetxt(tmp_path / "x0.txt", Sequence.open(synthetic).x0)
    seq = open_he(damaged, x0=str(tmp_path / "x0.txt"))
    with pytest.raises(DataError, match=r"Walking_1.mat: none of the 3 tracked frames has ground-truth markers"):
        seq.ground_truth(3, "stop")


# --- x0 files cut short or damaged (Hypothesis: tests/helpers.py damages) --------------------

SMALL_X0 = np.round(np.random.default_rng(2).uniform(-3, 3, 51), 6)


@pytest.fixture(scope="module")
def x0_files(tmp_path_factory):
    """The pose :data:`SMALL_X0` as the text file np.savetxt writes and as a .npy file."""
    folder = tmp_path_factory.mktemp("x0")
    np.savetxt(folder / "x0.txt", SMALL_X0)
    np.save(folder / "x0.npy", SMALL_X0)
    return {name: (folder / name, (folder / name).read_bytes()) for name in ("x0.txt", "x0.npy")}


@pytest.mark.parametrize("name", ["x0.txt", "x0.npy"])
@settings(max_examples=60)
@given(data=st.data())
def test_a_damaged_x0_file_is_refused_or_read_whole(x0_files, name, data):
    path, whole = x0_files[name]
    damage = data.draw(damages(whole))
    outcome = read_damaged(read_pose_file, path, damage, whole)
    if damage.kind == "cut":
        assert outcome is None, f"{damage}: read, not refused"
