"""Silhouette evaluators: the shared rule, the naive reference and the NumPy backend."""

import numpy as np
import pytest

from mmocap.api import Evaluator
from mmocap.camera import Camera
from mmocap.errors import ConfigError, DataError
from mmocap.evaluators.naive import NaiveEvaluator
from mmocap.evaluators.numpy_backend import MAX_DILATE_SIDE, NumpyEvaluator
from mmocap.evaluators.silhouette import fitness_from_counts, view_geometry
from mmocap.testing.evaluators import (
    FRONT,
    HIGH,
    RIGS,
    SIDE,
    TRUE_POSE,
    BlobBody,
    H,
    PlateBody,
    PointBody,
    W,
    empty_masks,
    test_poses,
)

BACKENDS = [NaiveEvaluator, NumpyEvaluator]


@pytest.fixture(scope="module")
def body():
    return BlobBody()


def own_render(backend, body, cameras, x):
    """Foreground masks equal to the model's own silhouettes of pose x."""
    with backend() as ev:
        ev.setup(body, cameras, empty_masks(cameras))
        return [ev.render(x, c) for c in range(len(cameras))]


def test_backends_meet_the_protocol():
    for backend in BACKENDS:
        assert isinstance(backend(), Evaluator)


def test_fitness_from_counts_follows_eq6_and_the_empty_cases():
    model = np.array([[100, 0, 0, 50, 40]])
    overlap = np.array([[100, 0, 0, 0, 10]])
    fg = np.array([100, 0, 30, 0, 20])
    # perfect, both empty, model empty, foreground empty, partial: 30/80 + 10/40
    expected = np.array([0.0, 0.0, 1.0, 1.0, 30 / 80 + 10 / 40])
    np.testing.assert_allclose(fitness_from_counts(model, overlap, fg), [expected.mean()])
    for c in range(5):
        f = fitness_from_counts(model[:, c : c + 1], overlap[:, c : c + 1], fg[c : c + 1])
        assert f[0] == pytest.approx(expected[c])


@pytest.mark.parametrize("backend", BACKENDS)
def test_perfect_match_scores_zero_and_no_overlap_one(backend, body):
    cameras = [FRONT, SIDE]
    fg = own_render(backend, body, cameras, TRUE_POSE)
    assert all(m.sum() > 500 for m in fg)
    with backend() as ev:
        ev.setup(body, cameras, fg)
        np.testing.assert_array_equal(ev(TRUE_POSE[None]), [0.0])
        model_px, overlap_px = ev.counts(TRUE_POSE[None])
        np.testing.assert_array_equal(model_px, [[m.sum() for m in fg]])
        np.testing.assert_array_equal(overlap_px, model_px)
        # foreground only where the model is not
        ev.setup(body, cameras, [~m for m in fg])
        np.testing.assert_array_equal(ev(TRUE_POSE[None]), [1.0])


@pytest.mark.parametrize("backend", BACKENDS)
def test_empty_foreground_and_model_outside_the_view(backend, body):
    cameras = [FRONT, SIDE]
    away = TRUE_POSE + np.r_[-2000.0, 0, 0, np.zeros(5)]  # out of the front view, in the side one
    with backend() as ev:
        ev.setup(body, cameras, empty_masks(cameras))
        model_px, _ = ev.counts(away[None])
        assert model_px[0, 0] == 0
        assert model_px[0, 1] > 0
        f = ev(np.stack([TRUE_POSE, away]))
        # a view with model and no foreground scores 1, one with neither 0; fused by the mean
        np.testing.assert_array_equal(f, [1.0, 0.5])
        ev.setup(body, cameras, own_render(backend, body, cameras, TRUE_POSE))
        f = ev(away[None])
        assert ev.counts(away[None])[0][0, 0] == 0  # front: foreground, no model: f_c = 1
        assert np.isfinite(f).all()
        assert 0.5 < f[0] < 1.0


def test_conformance_cases_reach_every_numpy_path():
    """The conformance suite (which compares numpy with naive) covers numpy's special paths:
    even patch sides, sides above MAX_DILATE_SIDE (views rendered one by one), joints
    behind a camera, and a model leaving the image."""
    X = test_poses()
    _, side = view_geometry(BlobBody(), RIGS["front-side-near"], X, 3.0)
    assert (side > MAX_DILATE_SIDE).any()
    _, side = view_geometry(BlobBody(), RIGS["front-side-near"], X, 1.0)
    assert ((side > 0) & (side % 2 == 0)).any()
    _, side = view_geometry(BlobBody(), RIGS["high-inside-small"], X, 1.0)
    assert (side[:, 1] == 0).any()  # joints whose pivot is behind the inside camera
    with NaiveEvaluator() as naive:
        naive.setup(BlobBody(), [FRONT], empty_masks([FRONT]))
        front = naive.render(X[-2], 0)  # the pose partly outside the front view
        assert front[:, -1].any()
        assert front.sum() < naive.render(TRUE_POSE, 0).sum()


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("side", [1, 2, 3, 4, 5, 6])
def test_patch_covers_the_documented_pixels(backend, side):
    """A lone vertex projecting to (100.3, 50.7) covers cx-(s-1)//2 .. cx+s//2 around (100, 51)."""
    cam = Camera.look_at("point", (0, 0, -1000), (0, 0, 0), 500.0, 200, 120)
    assert cam.K[0, 2] == 99.5
    assert cam.K[1, 2] == 59.5
    # f * patch_mm * scale / z = side - 0.5, so the patch side is exactly `side`
    ev = backend(patch_scale=(side - 0.5) / (500.0 * 2.0 / 1000))
    ev.setup(PointBody(ev.patch_scale), [cam], empty_masks([cam]))
    x = np.array([-1.6, 17.6, 0.0])  # camera x, y = world -x, -y: u = 99.5 + 0.8, v = 59.5 - 8.8
    image = ev.render(x, 0)
    rows, cols = np.nonzero(image)
    assert (cols.min(), cols.max()) == (100 - (side - 1) // 2, 100 + side // 2)
    assert (rows.min(), rows.max()) == (51 - (side - 1) // 2, 51 + side // 2)
    assert image.sum() == side * side
    # a vertex one pixel left of the image still covers its patch's columns inside it
    image = ev.render(x + np.r_[202.0, 0, 0], 0)
    assert image.sum() == side * (side // 2)
    if side > 1:
        assert image[:, : side // 2].all(axis=1).sum() == side


@pytest.mark.parametrize("backend", BACKENDS)
def test_back_faces_are_culled(backend):
    front = Camera.look_at("front", (0, 0, 1000), (0, 0, 0), 300.0, 160, 120)
    back = Camera.look_at("back", (0, 0, -1000), (0, 0, 0), 300.0, 160, 120)
    body = PlateBody()
    with backend() as ev:
        ev.setup(body, [front, back], empty_masks([front, back]))
        model_px, _ = ev.counts(np.zeros((1, 3)))
        assert model_px[0, 0] > 2000
        assert model_px[0, 1] == 0


@pytest.mark.parametrize("backend", BACKENDS)
def test_fitness_decreases_as_the_pose_approaches_the_truth(backend, body):
    cameras = [FRONT, SIDE, HIGH]
    fg = own_render(backend, body, cameras, TRUE_POSE)
    offsets = np.array([400.0, 200, 100, 40, 15, 0])
    X = np.repeat(TRUE_POSE[None], len(offsets), axis=0)
    X[:, 0] += offsets
    X[:, 1] -= offsets / 2
    with backend() as ev:
        ev.setup(body, cameras, fg)
        f = ev(X)
    assert np.all(np.diff(f) < 0)
    assert f[-1] == 0.0
    assert f[0] > 0.5


@pytest.mark.parametrize("backend", BACKENDS)
def test_setup_and_input_errors(backend, body):
    ev = backend()
    with pytest.raises(RuntimeError, match="setup"):
        ev(TRUE_POSE[None])
    masks = empty_masks([FRONT, SIDE])
    masks[1] = np.zeros((H, W + 1), bool)
    with pytest.raises(DataError, match=r"side.*\(240, 321\).*\(240, 320\)"):
        ev.setup(body, [FRONT, SIDE], masks)
    with pytest.raises(DataError, match="1 foreground masks for 2 cameras"):
        ev.setup(body, [FRONT, SIDE], masks[:1])
    with pytest.raises(ConfigError, match="patch_scale"):
        backend(patch_scale=0.0)
    ev.setup(body, [FRONT], empty_masks([FRONT]))
    X = np.repeat(TRUE_POSE[None], 3, axis=0)
    X[2, 4] = np.nan
    with pytest.raises(ValueError, match="row 2"):
        ev(X)
    with pytest.raises(ValueError, match=r"\(n, P\)"):
        ev(TRUE_POSE)
    with pytest.raises(IndexError):
        ev.render(TRUE_POSE, 1)
    ev.close()
    with pytest.raises(RuntimeError):
        ev.counts(TRUE_POSE[None])


def test_projection_coefficients_project_and_cull_as_the_camera_does():
    """u'/z and v'/z from A, and n . v + n . b from b, against the camera-frame point
    p = M [v; 1] and normal n' = R n, for M = E_c T_j = [R t] of random poses; the patch
    side from the camera-frame depth of the joint's rest position."""
    body, cameras, X = BlobBody(), RIGS["front-side-near"] + RIGS["high-inside-small"], test_poses()
    coefficients, side = view_geometry(body, cameras, X, 1.0)
    coefficients = coefficients.astype(np.float64)  # (n, C, J, 16)
    E = np.stack([cam.extrinsic for cam in cameras])
    M = E[None, :, None] @ body.transforms(X)[:, None]  # (n, C, J, 4, 4)
    K = np.stack([cam.K for cam in cameras])
    pivots = np.c_[body.joint_rest_positions, np.ones(len(body.joint_rest_positions))]
    depth = np.einsum("ncjk,jk->ncj", M[..., 2, :], pivots)
    focal_patch = np.array([cam.focal for cam in cameras])[:, None] * np.asarray(body.patch_mm)
    expected_side = np.where(depth > 1.0, np.maximum(np.ceil(focal_patch / depth), 1), 0)
    np.testing.assert_array_equal(side, expected_side)
    rng = np.random.default_rng(3)
    v = rng.uniform(-300, 300, 3)
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    p = M[..., :3, :3] @ v + M[..., :3, 3]  # (n, C, J, 3)
    rotated = M[..., :3, :3] @ normal
    A = coefficients[..., :12].reshape(M.shape[:3] + (3, 4))
    projected = A @ np.r_[v, 1.0]
    in_front = p[..., 2] > 100
    for row in (0, 1):
        expected = np.einsum("ck,ncjk->ncj", K[:, row], p) / p[..., 2]
        np.testing.assert_allclose((projected[..., row] / projected[..., 2])[in_front], expected[in_front], atol=1e-3)
    culling = normal @ v + np.einsum("ncjk,k->ncj", coefficients[..., 12:15], normal)
    np.testing.assert_allclose(culling, np.einsum("ncjk,ncjk->ncj", rotated, p), atol=1e-2)
