import json

import cv2
import numpy as np
import pandas as pd
import pytest

from mmocap.body.keypoints import model_points, posed_points
from mmocap.body.model import MARKER_NAMES, BodyModel
from mmocap.camera import Camera
from mmocap.data.keypoints import openpose_path
from mmocap.data.motion import ACTIONS, generate_motion
from mmocap.data.realism import Realism
from mmocap.data.sequence import Sequence
from mmocap.data.skeletons import HALPE_26, MAPPINGS
from mmocap.data.synthetic import camera_rig, generate
from mmocap.errors import ConfigError, DataError
from mmocap.stages.accuracy import marker_error
from tests.helpers import TINY


def test_layout_on_disk(tiny_sequence):
    root = tiny_sequence
    meta = json.loads((root / "sequence.json").read_text())
    assert meta["format"] == "mmocap-sequence/1"
    assert meta["cameras"] == ["C1", "C2", "BW1"]
    assert meta["frames"] == 4
    assert meta["fps"] == 60.0
    assert meta["subject"] == "S1"
    assert meta["dimensions"]["height_mm"] == 1780.0
    assert len(meta["x0"]) == 51
    for cam in meta["cameras"]:
        assert (root / "calibration" / f"{cam}.json").is_file()
        assert len(list((root / "background" / cam).glob("*.png"))) == 3
        assert len(list((root / "images" / cam).glob("*.png"))) == 4
        assert len(list((root / "silhouettes" / cam).glob("*.png"))) == 4
    colour = cv2.imread(str(root / "images" / "C1" / "000000.png"), cv2.IMREAD_UNCHANGED)
    grey = cv2.imread(str(root / "images" / "BW1" / "000000.png"), cv2.IMREAD_UNCHANGED)
    assert colour.shape == (240, 320, 3)
    assert grey.shape == (240, 320)
    table = pd.read_csv(root / "markers_mm.csv")
    assert list(table.columns) == ["frame", "marker", "x_mm", "y_mm", "z_mm"]
    assert len(table) == 4 * len(MARKER_NAMES)
    assert np.load(root / "poses.npy").shape == (4, 51)
    assert not (root / "pose").exists()  # exact: no keypoint detector, no keypoint files


def test_ground_truth_is_consistent_but_not_the_trackers_model(tiny_sequence):
    seq = Sequence.open(tiny_sequence)
    truth = seq.markers()
    poses = np.load(tiny_sequence / "poses.npy")
    np.testing.assert_allclose(seq.x0, poses[0])
    body = BodyModel("S1")
    err = marker_error(body.markers(poses), truth)
    # the tracker's rigid markers at the true pose sit close to, but not exactly on, the
    # skinned mesh's markers: the data is not rendered from the tracker's own model
    assert np.all(err < 15)
    assert np.all(err > 0.05)
    # the person is in every view: silhouettes cover a sensible part of the image
    for cam in seq.cameras:
        area = seq.silhouette(0, cam).mean()
        assert 0.01 < area < 0.5, cam.name
    # and the markers project inside the silhouettes (through the real, distorted lens)
    cam = seq.cameras[0]
    uv = np.round(cam.project(truth[0])).astype(int)
    sil = cv2.dilate(seq.silhouette(0, cam).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert sil[uv[:, 1], uv[:, 0]].mean() > 0.9


@pytest.mark.parametrize("action", ACTIONS)
def test_motion_is_smooth_and_moves(action):
    poses = generate_motion(action, 120, 60.0, floor_offset_mm=950.0, seed=2)
    step = np.abs(np.diff(poses[:, 3:], axis=0)).max()
    assert step < 0.25  # rad per frame at 60 fps: fast punches, but within the 0.5 rad radius
    assert np.ptp(poses[:, 3:], axis=0).max() > 0.5  # something moves a lot
    assert np.all(poses[:, 1] > 700)  # the root stays above the floor


def test_sequence_reader_errors(tiny_sequence, tmp_path):
    with pytest.raises(DataError, match="camera C3 not in sequence"):
        Sequence.open(tiny_sequence, cameras=["C1", "C3"])
    with pytest.raises(DataError, match="no sequence.json"):
        Sequence.open(tmp_path)
    with pytest.raises(ConfigError, match="unknown action"):
        generate_motion("juggling", 10, 60.0, 950.0)


def _outside_darker(seq, cam, frame=0, ratio=0.8):
    """(H, W) bool: pixels outside the silhouette darker than ``ratio`` of the empty scene."""
    empty = np.mean(seq.background(cam), axis=0)
    image = seq.images(frame)[seq.cameras.index(cam)].astype(float)
    darker = (image + 1) / (empty + 1) < ratio
    return (darker.all(axis=2) if darker.ndim == 3 else darker) & ~seq.silhouette(frame, cam)


def test_lighting_flickers_and_the_person_casts_a_shadow(tiny_sequence):
    seq = Sequence.open(tiny_sequence)
    gains = []
    for cam in seq.cameras:
        means = np.array([frame.mean() for frame in seq.background(cam)])
        gains.append(means / means[0])
        shadow = _outside_darker(seq, cam)
        assert shadow.sum() > 200, cam.name
        # on the floor, at the feet: below the silhouette's centre
        assert np.nonzero(shadow)[0].mean() > np.nonzero(seq.silhouette(0, cam))[0].mean(), cam.name
    gains = np.array(gains)
    assert np.ptp(gains[0]) > 0.005  # the light's gain changes frame to frame
    np.testing.assert_allclose(gains, gains[[0]].repeat(len(gains), 0), atol=2e-3)  # one light for all


def test_lighting_effects_can_be_turned_off(tmp_path):
    root = generate(
        tmp_path / "plain",
        frames=1,
        cameras=("C1",),
        width=160,
        height=120,
        background_frames=3,
        flicker=0.0,
        shadow_strength=0.0,
        shot_noise=0.0,
        progress=False,
    )
    seq = Sequence.open(root)
    cam = seq.cameras[0]
    means = [frame.mean() for frame in seq.background(cam)]
    assert np.ptp(means) / means[0] < 1e-3
    assert _outside_darker(seq, cam).sum() < 5  # only noise


@pytest.mark.parametrize(
    "kwargs",
    [
        {"flicker": -0.1},
        {"shadow_strength": 1.5},
        {"shot_noise": -1.0},
        {"shadow_softness": 2.0},
        {"noise_sigma": -2.0},
    ],
)
def test_bad_lighting_settings_name_the_value(tmp_path, kwargs):
    name = next(iter(kwargs))
    with pytest.raises(ConfigError, match=f"dataset.{name} must be a number in"):
        generate(tmp_path / "bad", frames=1, cameras=("C1",), progress=False, **kwargs)


def test_a_damaged_sequence_json_is_rendered_again(tmp_path):
    from mmocap.data.synthetic import SyntheticDataset

    dataset = SyntheticDataset(
        root=str(tmp_path), frames=1, cameras=["C1"], all_cameras=["C1"], width=64, height=48, background_frames=2
    )
    dataset.open(progress=False)
    (dataset.path / "sequence.json").write_text('{"format": "mmocap-seq')
    assert dataset.open(progress=False).n_frames == 1


@pytest.mark.parametrize(("width", "height"), [(1920, 1080), (640, 720)])
def test_any_image_shape_keeps_the_640x480_field_of_view(width, height):
    names = ["C1", "C2", "C3", "BW1"]
    base = camera_rig(names, 640, 480, np.random.default_rng(0))
    other = camera_rig(names, width, height, np.random.default_rng(0))
    for small, large in zip(base, other):
        np.testing.assert_allclose(large.R, small.R)
        # the tangents of the half fields of view, across and up
        wide, tall = width / 2 / large.K[0, 0], height / 2 / large.K[1, 1]
        small_wide, small_tall = 320 / small.K[0, 0], 240 / small.K[1, 1]
        assert wide >= small_wide - 1e-12  # sees at least as far to the sides
        assert tall >= small_tall - 1e-12  # and up and down
        assert min(wide / small_wide, tall / small_tall) == pytest.approx(1)  # and no further in one of them


def test_a_4_by_3_image_keeps_its_focal_length_per_pixel():
    base = camera_rig(["C1"], 640, 480, np.random.default_rng(0))[0]
    half = camera_rig(["C1"], 320, 240, np.random.default_rng(0))[0]
    assert half.K[0, 0] == base.K[0, 0] / 2


def test_keypoints_are_the_true_joints_seen_through_the_real_lens(tmp_path):
    # a detector without error, and nothing else departing: its keypoints are the body's
    # joint centres and nose projected through the written (here: true) camera, distorted
    root = generate(tmp_path / "keypoints", progress=False, realism=Realism(detector="HALPE_26"), **TINY)
    mapping = MAPPINGS["HALPE_26"]
    names = [name for name in HALPE_26 if name in mapping]
    body = BodyModel("S1")
    joint, rest = model_points(body, [mapping[name][0] for name in names], [mapping[name][1] for name in names])
    world = posed_points(body, np.load(root / "poses.npy"), joint, rest)
    index = [HALPE_26.index(name) for name in names]
    for name in TINY["cameras"]:
        camera = Camera.load(root / "calibration" / f"{name}.json")
        assert np.any(camera.dist != 0)
        for frame in range(TINY["frames"]):
            path = openpose_path(root, name, frame)
            assert path == root / "pose" / f"{name}_json" / f"{name}_{frame:06d}.json"
            (person,) = json.loads(path.read_text())["people"]
            values = np.array(person["pose_keypoints_2d"]).reshape(len(HALPE_26), 3)
            np.testing.assert_allclose(values[index, :2], camera.project(world[frame]), atol=1e-3)
            assert np.all(values[index, 2] >= 0.7)
            unmapped = np.ones(len(HALPE_26), bool)
            unmapped[index] = False
            np.testing.assert_array_equal(values[unmapped], 0.0)  # eyes, ears, feet: not simulated
    drawn = json.loads((root / "sequence.json").read_text())["realism"]["keypoints"]
    assert drawn["missed"] == drawn["outside"] == drawn["swapped"] == 0
    assert all(offset == [0.0, 0.0, 0.0] for offset in drawn["offsets_mm"].values())
