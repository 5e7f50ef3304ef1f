import dataclasses
import json

import cv2
import numpy as np
import pytest
from hydra import compose, initialize_config_module

from mmocap.body.kinematics import global_transforms, skinning_transforms
from mmocap.body.mesh import SUBJECTS, fit_subject, load_makehuman
from mmocap.body.model import marker_vertices, rest_frames
from mmocap.camera import Camera
from mmocap.data import realism as realism_draws
from mmocap.data.keypoints import openpose_path
from mmocap.data.realism import Realism
from mmocap.data.sequence import Sequence
from mmocap.data.skeletons import HALPE_26, MAPPINGS
from mmocap.data.synthetic import SyntheticDataset, generate
from mmocap.errors import ConfigError
from tests.helpers import TINY

REALISTIC = dict(
    name="realistic",
    height_sd_mm=20.0,
    girth_sd=0.05,
    marker_standoff_mm=9.0,
    marker_placement_sd_mm=10.0,
    rotation_sd_deg=0.05,
    translation_sd_mm=2.0,
    focal_sd=0.002,
    principal_point_sd_px=0.7,
    sync_frames=0.25,
    camouflage=0.3,
    detector="HALPE_26",
    keypoint_noise=0.5,
    keypoint_miss_rate=0.02,
    keypoint_swap_rate=0.01,
    keypoint_offset_sd_mm=15.0,
)
#: the settings of the simulated detector, which ``exact`` leaves off
DETECTOR_KEYS = ("detector", "keypoint_noise", "keypoint_miss_rate", "keypoint_swap_rate", "keypoint_offset_sd_mm")


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """The tiny sequence rendered exact and with a strong realism (same seed)."""
    root = tmp_path_factory.mktemp("realism")
    strong = Realism(
        **{**REALISTIC, "name": "strong", "height_sd_mm": 60.0, "rotation_sd_deg": 0.5, "translation_sd_mm": 20.0}
    )
    exact = generate(root / "exact", progress=False, **TINY)
    other = generate(root / "strong", progress=False, realism=strong, **TINY)
    return exact, other, strong


def _files(root):
    """Every file under ``root`` but sequence.json and the keypoint files, by relative path."""
    return {
        str(path.relative_to(root)): path.read_bytes()
        for path in sorted(root.rglob("*"))
        if path.is_file() and path.name != "sequence.json" and "pose" not in path.relative_to(root).parts
    }


def test_the_detector_leaves_every_other_file_unchanged(pair, tmp_path):
    exact, other, strong = pair
    assert strong.detector == "HALPE_26"
    without = dataclasses.replace(
        strong, **{key: Realism.detector if key == "detector" else 0.0 for key in DETECTOR_KEYS}
    )
    plain = generate(tmp_path / "plain", progress=False, realism=without, **TINY)
    assert not (plain / "pose").exists()
    assert (other / "pose").is_dir()
    files, plain_files = _files(other), _files(plain)
    assert sorted(files) == sorted(plain_files)
    assert len(files) > 30
    for name, content in files.items():
        assert content == plain_files[name], name  # images, silhouettes, calibration, markers, poses
    meta, plain_meta = (json.loads((root / "sequence.json").read_text()) for root in (other, plain))
    keypoints = meta["realism"].pop("keypoints")
    assert keypoints["detector"] == "HALPE_26"
    assert meta["realism"] == plain_meta["realism"]  # every other draw is the same
    for data in (meta, plain_meta):
        del data["generator"]
    assert meta == plain_meta


def test_exact_writes_no_keypoints(pair):
    exact, _, _ = pair
    assert not (exact / "pose").exists()
    assert "keypoints" not in json.loads((exact / "sequence.json").read_text())["realism"]
    assert Realism().detector is None


def test_what_the_detector_drew_is_recorded(pair):
    _, other, strong = pair
    drawn = json.loads((other / "sequence.json").read_text())["realism"]["keypoints"]
    joints = [name for name in HALPE_26 if name in MAPPINGS["HALPE_26"]]
    assert list(drawn["offsets_mm"]) == joints
    offsets = np.array(list(drawn["offsets_mm"].values()))
    assert offsets.shape == (15, 3)
    assert 0.4 * strong.keypoint_offset_sd_mm < offsets.std() < 1.6 * strong.keypoint_offset_sd_mm
    assert drawn["detections"] == TINY["frames"] * len(TINY["cameras"]) * 15
    # the files hold what was counted: the joints reported (confidence > 0) are those not missed
    reported = 0
    for camera in TINY["cameras"]:
        for frame in range(TINY["frames"]):
            people = json.loads(openpose_path(other, camera, frame).read_text())["people"]
            values = np.array(people[0]["pose_keypoints_2d"]).reshape(-1, 3)
            assert values.shape == (26, 3)
            reported += int(np.count_nonzero(values[:, 2]))
            assert np.all(values[values[:, 2] > 0, 2] >= 0.7)
    assert reported == drawn["detections"] - drawn["missed"] - drawn["outside"]


def _spread_out(n: int, realism: Realism, seed: int = 0):
    """A camera, the detector's joints and ``n`` frames of them 3 m in front of it, spread
    over the middle of the image, with their detections at a scale of 100 px."""
    camera = Camera.look_at("C1", (0, 1000, 3000), (0, 1000, 0), 600.0, 640, 480, np.zeros(5))
    rng = np.random.default_rng(seed)
    joints = realism_draws.detector_joints(realism.detector, realism.keypoint_offset_sd_mm, rng)
    world = np.stack(
        [rng.uniform(-600, 600, (n, 15)), 1000 + rng.uniform(-500, 500, (n, 15)), rng.uniform(-200, 200, (n, 15))],
        axis=2,
    )
    found, counts = realism_draws.detections(camera, world, np.full(n, 100.0), joints, realism, rng)
    true = camera.project(world.reshape(-1, 3)).reshape(n, 15, 2)
    return joints, true, found, counts


def test_detections_scatter_by_cocos_sigmas_at_the_persons_scale():
    realism = Realism(detector="HALPE_26", keypoint_noise=1.5)
    joints, true, found, counts = _spread_out(2000, realism)
    assert counts == {"missed": 0, "outside": 0, "swapped": 0}
    detected = found[:, joints.index]
    sigmas = joints.sigmas()
    # per axis: 1.5 x COCO's sigma x the scale (100 px) / sqrt(2); the hips the most, the nose the least
    for k, name in enumerate(joints.names):
        residual = (detected[:, k, :2] - true[:, k]).ravel()
        assert residual.std() == pytest.approx(1.5 * sigmas[k] * 100 / np.sqrt(2), rel=0.05), name
        assert abs(residual.mean()) < 0.1 * residual.std(), name
    assert {joints.points[k] for k in np.flatnonzero(sigmas == sigmas.max())} == {"LHip", "RHip", "Root"}
    assert joints.points[int(np.argmin(sigmas))] == "Nose"
    assert np.all((detected[..., 2] >= 0.7) & (detected[..., 2] <= 1.0))


def test_detections_miss_and_swap_at_the_set_rates():
    realism = Realism(detector="HALPE_26", keypoint_noise=0.05, keypoint_miss_rate=0.1, keypoint_swap_rate=0.2)
    n = 3000
    joints, true, found, counts = _spread_out(n, realism)
    detected = found[:, joints.index]
    seen = detected[..., 2] > 0
    # misses at the rate (nothing falls outside the image here), written 0, 0, 0
    assert counts["outside"] == 0
    assert counts["missed"] == np.count_nonzero(~seen)
    assert abs(counts["missed"] / (n * 15) - 0.1) < 0.01
    np.testing.assert_array_equal(detected[~seen], 0.0)
    # swaps, per frame and left/right pair: the left joint lies at the right one's place
    assert [(joints.points[a], joints.points[b]) for a, b in joints.pairs] == [
        ("LShoulder", "RShoulder"),
        ("LElbow", "RElbow"),
        ("LWrist", "RWrist"),
        ("LHip", "RHip"),
        ("LKnee", "RKnee"),
        ("LAnkle", "RAnkle"),
    ]
    left, right = joints.pairs.T
    at_right = seen[:, left] & (np.linalg.norm(detected[:, left, :2] - true[:, right], axis=2) < 3)
    at_left = seen[:, right] & (np.linalg.norm(detected[:, right, :2] - true[:, left], axis=2) < 3)
    apart = np.linalg.norm(true[:, left] - true[:, right], axis=2) > 10
    both = seen[:, left] & seen[:, right] & apart
    np.testing.assert_array_equal(at_right[both], at_left[both])  # both joints of the pair move
    assert abs(at_right[both].mean() - 0.2) < 0.02
    assert counts["swapped"] == pytest.approx(0.2 * n * 6, rel=0.05)
    # swapped joints are as confident as the others (a detector does not know)
    assert abs(detected[:, left, 2][at_right].mean() - detected[seen, 2].mean()) < 0.01


def test_joints_outside_the_image_are_missed():
    realism = Realism(detector="HALPE_26")
    joints = realism_draws.detector_joints("HALPE_26", 0.0, np.random.default_rng(0))
    camera = Camera.look_at("C1", (0, 1000, 3000), (0, 1000, 0), 600.0, 640, 480, np.zeros(5))
    world = np.zeros((1, 15, 3))
    world[0, :, 1] = 1000
    world[0, 0, 0] = 5000  # far to the side: outside the image
    found, counts = realism_draws.detections(camera, world, np.ones(1), joints, realism, np.random.default_rng(0))
    assert counts == {"missed": 0, "outside": 1, "swapped": 0}
    assert found[0, joints.index[0]].tolist() == [0.0, 0.0, 0.0]
    np.testing.assert_allclose(found[0, joints.index[1:], :2], camera.project(world[0, 1:]))


def test_every_mapped_model_point_has_a_coco_sigma():
    for mapping in MAPPINGS.values():
        assert {point for point, _ in mapping.values()} <= set(realism_draws.COCO_SIGMAS)


def test_the_config_group_composes_every_level():
    with initialize_config_module(config_module="conf", version_base=None):
        for level in ("exact", "realistic", "hard"):
            cfg = compose("config", overrides=[f"realism={level}"])
            realism = Realism.from_config(cfg.dataset.realism)
            assert realism.name == level
        assert Realism.from_config(compose("config").dataset.realism) == Realism()
        assert Realism.from_config(compose("config", overrides=["realism=realistic"]).realism) == Realism(**REALISTIC)


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"height_mm": 3}, r"realism: unknown setting\(s\) height_mm; known: camouflage"),
        ({"sync_frames": 2}, r"realism.sync_frames must be a number in \[0.0, 0.5\], got 2"),
        ({"girth_sd": -0.1}, r"realism.girth_sd must be a number in"),
        ({"name": 3}, r"realism.name must be a name, got 3"),
        ({"detector": "OPENPOSE"}, r"realism.detector: unknown keypoint skeleton 'OPENPOSE'; known: HALPE_26"),
        ({"detector": 25}, r"realism.detector must be a skeleton's name or null, got 25"),
        ({"keypoint_swap_rate": 1.5}, r"realism.keypoint_swap_rate must be a number in \[0.0, 1.0\], got 1.5"),
    ],
)
def test_bad_settings_name_the_key(values, message):
    with pytest.raises(ConfigError, match=message):
        Realism.from_config(values)


def test_realism_departs_from_exact_in_every_respect(pair):
    exact, other, strong = pair
    meta_exact = json.loads((exact / "sequence.json").read_text())
    meta = json.loads((other / "sequence.json").read_text())
    # the person rendered is not the preset the tracker assumes
    assert meta_exact["dimensions"] == {"height_mm": 1780.0, "girth": 1.0}
    assert abs(meta["dimensions"]["height_mm"] - 1780.0) > 1
    assert meta["dimensions"]["girth"] != 1.0
    # the motion is the same (the root's height follows the person's legs)
    poses_exact, poses = np.load(exact / "poses.npy"), np.load(other / "poses.npy")
    np.testing.assert_array_equal(np.delete(poses_exact, 1, axis=1), np.delete(poses, 1, axis=1))
    # the written calibration is off by what sequence.json records
    for name, drawn in meta["realism"]["cameras"].items():
        true = Camera.load(exact / "calibration" / f"{name}.json")
        seen = Camera.load(other / "calibration" / f"{name}.json")
        turn = np.rad2deg(np.linalg.norm(cv2.Rodrigues(seen.R @ true.R.T)[0]))
        assert turn == pytest.approx(drawn["rotation_deg"], abs=1e-6)
        moved = np.linalg.norm(seen.R.T @ seen.t - true.R.T @ true.t)
        assert moved == pytest.approx(drawn["position_mm"], rel=1e-6)
        assert abs(drawn["time_offset_frames"]) <= strong.sync_frames
    assert max(d["position_mm"] for d in meta["realism"]["cameras"].values()) > 5
    # exact writes no error at all
    for d in meta_exact["realism"]["cameras"].values():
        assert d.pop("reprojection_px") < 1e-9
        assert d == {
            "rotation_deg": 0.0,
            "position_mm": 0.0,
            "focal": 0.0,
            "principal_point_px": [0.0, 0.0],
            "time_offset_frames": 0.0,
        }
    assert all(d["reprojection_px"] > 0.5 for d in meta["realism"]["cameras"].values())


def test_markers_stand_off_the_skin_by_the_set_amount(pair):
    exact, other, strong = pair
    # same body, same motion: only the markers' offsets differ between these two
    same_body = Realism(marker_standoff_mm=9.0)
    mesh = fit_subject(load_makehuman(), SUBJECTS["S1"])
    indices = marker_vertices(mesh)
    offsets = realism_draws.marker_offsets(mesh, indices, same_body, np.random.default_rng(0))
    np.testing.assert_allclose(np.linalg.norm(offsets, axis=1), 9.0)
    poses = np.load(exact / "poses.npy")
    S = skinning_transforms(global_transforms(poses, mesh.pivots, rest_frames(mesh)), mesh.pivots)
    on_skin = realism_draws.posed_markers(mesh, indices, np.zeros_like(offsets), S)
    np.testing.assert_allclose(on_skin, np.stack([mesh.posed(s)[indices] for s in S]), atol=1e-9)
    np.testing.assert_allclose(on_skin, Sequence.open(exact).markers(), atol=1e-3)
    stood_off = realism_draws.posed_markers(mesh, indices, offsets, S)
    distance = np.linalg.norm(stood_off - on_skin, axis=2)
    assert np.all(np.abs(distance - 9.0) < 1.5)  # the skin stretches a little under skinning
    # in the rendered pair the markers moved by standoff and placement (and the body)
    moved = np.linalg.norm(Sequence.open(other).markers() - Sequence.open(exact).markers(), axis=2)
    assert 8 < np.median(moved) < 60


def test_poses_between_frames_are_interpolated():
    poses = np.arange(4)[:, None] * np.ones((4, 51))
    np.testing.assert_allclose(realism_draws.poses_at(poses, 0.25)[:, 0], [0.25, 1.25, 2.25, 3.25])
    np.testing.assert_allclose(realism_draws.poses_at(poses, -0.5)[:, 0], [-0.5, 0.5, 1.5, 2.5])
    assert realism_draws.poses_at(poses, 0.0) is poses


def test_camouflage_pulls_colours_to_the_scene():
    colours = np.array([[1.0, 0.0, 0.0]])
    scene = np.zeros((2, 2, 3), np.uint8)
    scene[..., 0] = 255  # blue in BGR
    np.testing.assert_allclose(realism_draws.camouflaged(colours, [scene], 0.25), [[0.75, 0, 0.25]])


def test_each_level_has_its_own_folder(tmp_path):
    exact = SyntheticDataset(root=str(tmp_path), frames=1, cameras=["C1"], all_cameras=["C1"])
    realistic = SyntheticDataset(root=str(tmp_path), frames=1, cameras=["C1"], all_cameras=["C1"], realism=REALISTIC)
    assert exact.path.name == "S1_walking"
    assert realistic.path.name == "S1_walking_realistic"
