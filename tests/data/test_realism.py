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
from mmocap.data.realism import Realism
from mmocap.data.sequence import Sequence
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
)


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
