"""Conformance suite for evaluator backends (pytest), and the small test bodies it uses.

Every evaluator registered under the ``mmocap.evaluators`` entry points must give the
pixel counts of the ``naive`` reference (:mod:`mmocap.evaluators.naive`) on the same
inputs, exactly: ``|M_c|`` and ``|M_c & F_c|`` are integers, and the rule of
:mod:`mmocap.evaluators.silhouette` fixes every float32 operation of the projection, so
backends agree bit for bit. The fitness, computed from the counts
by the shared :func:`~mmocap.evaluators.silhouette.fitness_from_counts`, is then equal too.
With 2-D keypoints (:func:`blob_keypoints`), every backend must also give the model points'
pixels of the ``numpy`` reference (:meth:`~mmocap.evaluators.silhouette.SilhouetteEvaluator.counts_and_pixels`),
bit for bit (NaN where a point is behind the camera), and so the same hybrid fitness.
A plugin reuses the suite in one line::

    from mmocap.testing.evaluators import EvaluatorConformance

    class TestMyEvaluator(EvaluatorConformance):
        name = "mybackend"      # the entry-point name; ``params`` may set constructor args

Cases: random poses seen by three cameras, a model partly outside a view, wholly outside
one, behind a camera and around a camera inside the body, very large patches (a camera
close to the body), several patch scales, an empty foreground, populations of 1 and 0,
patches at the image border, NaN poses, the config file, and keypoints in both rigs
(noisy, some not seen, points behind the INSIDE camera).
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mmocap import config, registry
from mmocap.api import Evaluator
from mmocap.body.keypoints import model_points
from mmocap.camera import Camera
from mmocap.evaluators.keypoint_term import Keypoints, KeypointTerm
from mmocap.evaluators.silhouette import PATCH_SCALE, keypoint_pixels, view_geometry

W, H = 320, 240


def ellipsoid(centre, radii, count: int) -> tuple[np.ndarray, np.ndarray]:
    """(count, 3) evenly spread points on an ellipsoid (mm) and their (count, 3) outward normals."""
    i = np.arange(count) + 0.5
    polar, azimuth = np.arccos(1 - 2 * i / count), np.pi * (1 + 5**0.5) * i
    unit = np.stack([np.sin(polar) * np.cos(azimuth), np.cos(polar), np.sin(polar) * np.sin(azimuth)], axis=1)
    radii = np.asarray(radii, float)
    normals = unit / radii
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return np.asarray(centre, float) + unit * radii, normals


class BlobBody:
    """Stand-in body: pelvis, trunk and head ellipsoids on a chain of 3 joints (mm, y up).

    Pose (8,): root translation (3, mm), root rotation vector (3, rad), trunk and head
    bends about their pivots' x axes (rad).
    """

    PARTS = (  # centre, radii, pivot, vertex count
        ((0, 0, 0), (150, 100, 100), (0, 0, 0), 400),
        ((0, 400, 0), (90, 250, 80), (0, 150, 0), 700),
        ((0, 750, 0), (90, 90, 90), (0, 650, 0), 300),
    )

    def __init__(self):
        points, normals, joints, patch = [], [], [], []
        for j, (centre, radii, _, count) in enumerate(self.PARTS):
            p, n = ellipsoid(centre, radii, count)
            points.append(p)
            normals.append(n)
            joints.append(np.full(count, j))
            a, b, c = (r**1.6075 for r in radii)  # Thomsen's ellipsoid area, 1 % accurate
            area = 4 * np.pi * ((a * b + a * c + b * c) / 3) ** (1 / 1.6075)
            patch.append(np.sqrt(area / (2 * count)))
        self.rest_vertices = np.concatenate(points)
        self.rest_normals = np.concatenate(normals)
        self.vertex_joint = np.concatenate(joints)
        self.joint_rest_positions = np.array([part[2] for part in self.PARTS], float)
        self.patch_mm = np.array(patch)

    def transforms(self, X):
        X = np.atleast_2d(X)
        T = np.tile(np.eye(4), (len(X), 3, 1, 1))
        T[:, 0, :3, :3] = Rotation.from_rotvec(X[:, 3:6]).as_matrix()
        T[:, 0, :3, 3] = X[:, :3]
        for j, column in ((1, 6), (2, 7)):
            bend = np.tile(np.eye(4), (len(X), 1, 1))
            bend[:, :3, :3] = Rotation.from_euler("x", X[:, column, None]).as_matrix()
            pivot = self.joint_rest_positions[j]
            bend[:, :3, 3] = pivot - bend[:, :3, :3] @ pivot
            T[:, j] = T[:, j - 1] @ bend
        return T


class PlateBody:
    """One joint: a 200 x 200 mm plate of vertices in the z = 0 plane, normals +z."""

    def __init__(self):
        g = np.linspace(-100, 100, 21)
        xx, yy = np.meshgrid(g, g)
        self.rest_vertices = np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], axis=1)
        self.rest_normals = np.tile([0.0, 0.0, 1.0], (xx.size, 1))
        self.vertex_joint = np.zeros(xx.size, int)
        self.joint_rest_positions = np.zeros((1, 3))
        self.patch_mm = np.array([10.0])

    def transforms(self, X):
        T = np.tile(np.eye(4), (len(np.atleast_2d(X)), 1, 1, 1))
        T[:, 0, :3, 3] = np.atleast_2d(X)[:, :3]
        return T


class PointBody(PlateBody):
    """One joint with its pivot at the origin and one vertex facing -z, whose patch is
    centred on the origin for an evaluator of ``patch_scale`` (the skin vertex lies half a
    patch in front of it: see :func:`mmocap.evaluators.silhouette.vertex_table`); pose (3,)
    is its translation in mm."""

    def __init__(self, patch_scale: float):
        super().__init__()
        self.patch_mm = np.array([2.0])
        self.rest_vertices = np.array([[0.0, 0.0, -self.patch_mm[0] * patch_scale / 2]])
        self.rest_normals = np.array([[0.0, 0.0, -1.0]])
        self.vertex_joint = np.zeros(1, int)


def camera(name: str, eye, target=(0, 400, 0), focal: float = 400.0) -> Camera:
    """A W x H pin-hole at ``eye`` looking at ``target`` (mm)."""
    return Camera.look_at(name, eye, target, focal, W, H)


FRONT = camera("front", (300, 500, 3000))
SIDE = camera("side", (2800, 900, 400))
HIGH = camera("high", (-1500, 2500, -1800))
NEAR = camera("near", (0, 0, 450), (0, 0, 0))  # patches of 13 px and more
INSIDE = camera("inside", (0, 400, 40), (0, 400, 1000))  # in the trunk: pivots behind it
SMALL = Camera.look_at("small", (-2500, 800, 1500), (0, 400, 0), 250.0, 200, 150)
TRUE_POSE = np.array([30.0, -20.0, 50.0, 0.1, 0.3, -0.05, 0.4, -0.3])
RIGS = {"front-side-near": (FRONT, SIDE, NEAR), "high-inside-small": (HIGH, INSIDE, SMALL)}


def empty_masks(cameras) -> list[np.ndarray]:
    """One all-False (H_c, W_c) mask per camera."""
    return [np.zeros((cam.height, cam.width), bool) for cam in cameras]


def test_poses() -> np.ndarray:
    """(7, 8) blob poses: 4 random ones, the true pose, one partly outside FRONT, one far behind."""
    rng = np.random.default_rng(7)
    X = TRUE_POSE + rng.normal(0, 1, (4, 8)) * np.r_[150, 150, 150, 0.4, 0.4, 0.4, 0.5, 0.5]
    partly_outside = TRUE_POSE + np.r_[1100.0, 0, 0, np.zeros(5)]
    behind = TRUE_POSE + np.r_[0, 0, 5000.0, np.zeros(5)]
    return np.vstack([X, TRUE_POSE, partly_outside, behind])


test_poses.__test__ = False  # type: ignore[attr-defined]  # a helper, not a test (pytest reads __test__)


@cache
def true_masks(rig: str) -> tuple[np.ndarray, ...]:
    """The naive silhouettes of TRUE_POSE in the cameras of ``RIGS[rig]``: a foreground."""
    from mmocap.evaluators.naive import NaiveEvaluator

    cameras = RIGS[rig]
    with NaiveEvaluator() as ev:
        ev.setup(BlobBody(), cameras, empty_masks(cameras))
        return tuple(ev.render(TRUE_POSE, c) for c in range(len(cameras)))


@cache
def naive_counts(rig: str, patch_scale: float, foreground: str) -> tuple[np.ndarray, np.ndarray]:
    """Naive (model_px, overlap_px), (7, 3) each, of :func:`test_poses` in ``RIGS[rig]``."""
    from mmocap.evaluators.naive import NaiveEvaluator

    with NaiveEvaluator(patch_scale) as ev:
        ev.setup(BlobBody(), RIGS[rig], masks(rig, foreground))
        return ev.counts(test_poses())


#: the model points of the keypoint cases on BlobBody's three joints, as a detector's
#: joints mapped onto them: name and definition offset (mm) from the joint's pivot
BLOB_POINTS = (
    ("Root", (0.0, 0.0, 0.0)),
    ("Root", (110.0, -60.0, 20.0)),
    ("Root", (-110.0, -60.0, 20.0)),
    ("BottomSpine", (0.0, 0.0, 0.0)),
    ("BottomSpine", (95.0, 430.0, 0.0)),
    ("BottomSpine", (-95.0, 430.0, 0.0)),
    ("UpperSpine", (0.0, 0.0, 0.0)),
    ("UpperSpine", (0.0, 110.0, 85.0)),
)


@cache
def blob_keypoints(rig: str, weight: float = 0.5) -> Keypoints:
    """Keypoints of :data:`BLOB_POINTS` in ``RIGS[rig]``: TRUE_POSE's projections plus 3 px
    of noise, confidences in [0.3, 1], every fifth 0 (not seen), and 0 with NaN coordinates
    where a point lies behind the camera; the term of ``weight`` with its default loss."""
    body, cameras = BlobBody(), RIGS[rig]
    names = tuple(name for name, _ in BLOB_POINTS)
    offsets = np.array([offset for _, offset in BLOB_POINTS])
    joint, rest = model_points(body, names, offsets)
    coefficients, _ = view_geometry(body, cameras, TRUE_POSE[None], PATCH_SCALE)
    pixels = keypoint_pixels(coefficients, joint, rest)[0].astype(np.float64)  # (C, K, 2)
    rng = np.random.default_rng(3)
    confidence = rng.uniform(0.3, 1.0, pixels.shape[:2])
    confidence.ravel()[::5] = 0.0
    confidence[np.isnan(pixels[..., 0])] = 0.0
    observed = np.concatenate([pixels + rng.normal(0.0, 3.0, pixels.shape), confidence[..., None]], axis=2)
    return Keypoints(names, offsets, observed, KeypointTerm(weight=weight))


@cache
def numpy_reference(rig: str) -> tuple[np.ndarray, np.ndarray]:
    """The numpy backend's model points' pixels (7, C, K, 2) float32 and hybrid fitness
    (7,) of :func:`test_poses` with :func:`blob_keypoints` in ``RIGS[rig]``."""
    from mmocap.evaluators.numpy_backend import NumpyEvaluator

    with NumpyEvaluator() as ev:
        ev.setup(BlobBody(), RIGS[rig], masks(rig, "true"), blob_keypoints(rig))
        return ev.counts_and_pixels(test_poses())[2], ev(test_poses())


def masks(rig: str, foreground: str) -> list[np.ndarray]:
    """Foreground masks of a rig: ``true`` silhouettes, ``empty`` or ``full`` images."""
    cameras = RIGS[rig]
    if foreground == "true":
        return list(true_masks(rig))
    return [np.full((cam.height, cam.width), foreground == "full") for cam in cameras]


class EvaluatorConformance:
    """Subclass with ``name`` (entry-point name) and optionally ``params`` (constructor
    arguments) to run the suite on one evaluator."""

    name: str = ""
    params: dict = {}

    @pytest.fixture
    def evaluator_name(self) -> str:
        return self.name

    @pytest.fixture
    def make(self, evaluator_name):
        """Factory of fresh evaluators; extra keyword arguments override ``params``."""
        made = []

        def factory(**kw):
            made.append(registry.make_evaluator(evaluator_name, **{**self.params, **kw}))
            return made[-1]

        yield factory
        for ev in made:
            ev.close()

    def test_is_registered_and_follows_the_protocol(self, evaluator_name, make):
        assert evaluator_name in registry.available("evaluator")
        ev = make()
        assert isinstance(ev, Evaluator)
        with pytest.raises(RuntimeError, match="setup"):
            ev(TRUE_POSE[None])

    def test_config_file_composes_and_instantiates(self, evaluator_name):
        from hydra.utils import instantiate

        cfg = config.compose([f"evaluator={evaluator_name}"])
        assert cfg.evaluator.name == evaluator_name
        ev = instantiate(cfg.evaluator)
        assert isinstance(ev, Evaluator)
        ev.close()

    @pytest.mark.parametrize("rig", sorted(RIGS))
    @pytest.mark.parametrize("patch_scale", [0.3, 1.0, 1.7, 3.0])
    def test_counts_and_fitness_equal_naive(self, make, rig, patch_scale):
        from mmocap.evaluators.silhouette import fitness_from_counts

        ev = make(patch_scale=patch_scale)
        for foreground in ("true", "empty") if patch_scale == 1.0 else ("true",):
            ev.setup(BlobBody(), RIGS[rig], masks(rig, foreground))
            model_px, overlap_px = naive_counts(rig, patch_scale, foreground)
            got = ev.counts(test_poses())
            np.testing.assert_array_equal(got[0], model_px)
            np.testing.assert_array_equal(got[1], overlap_px)
            np.testing.assert_array_equal(ev(test_poses()), fitness_from_counts(model_px, overlap_px, ev.fg_px))
        # the cases the test is meant to cover occur: views with no model pixel at all
        assert model_px.min() == 0
        assert model_px.max() > 0

    @pytest.mark.parametrize("rig", sorted(RIGS))
    def test_keypoint_pixels_and_hybrid_fitness_equal_numpy(self, make, rig):
        from mmocap.evaluators.silhouette import fitness_from_counts

        pixels, fitness = numpy_reference(rig)
        model_px, overlap_px = naive_counts(rig, PATCH_SCALE, "true")
        ev = make()
        ev.setup(BlobBody(), RIGS[rig], masks(rig, "true"), blob_keypoints(rig))
        got = ev.counts_and_pixels(test_poses())
        np.testing.assert_array_equal(got[0], model_px)
        np.testing.assert_array_equal(got[1], overlap_px)
        assert got[2].dtype == np.float32
        assert got[2].shape == (len(test_poses()), len(RIGS[rig]), len(BLOB_POINTS), 2)
        np.testing.assert_array_equal(got[2].view(np.uint32), pixels.view(np.uint32))  # bits; NaN where NaN
        np.testing.assert_array_equal(ev(test_poses()), fitness)
        # the cases the test is meant to cover occur: points behind a camera, the term counts
        silhouette = fitness_from_counts(model_px, overlap_px, ev.fg_px)
        assert np.isnan(pixels).any()
        assert np.isfinite(pixels).any()
        assert (fitness > silhouette).all()
        # weight 0: the silhouettes' fitness alone
        ev.setup(BlobBody(), RIGS[rig], masks(rig, "true"), blob_keypoints(rig, weight=0.0))
        np.testing.assert_array_equal(ev(test_poses()), silhouette)

    def test_keypoints_of_a_population_of_zero(self, make):
        ev = make()
        ev.setup(
            BlobBody(), RIGS["front-side-near"], masks("front-side-near", "true"), blob_keypoints("front-side-near")
        )
        model_px, _, pixels = ev.counts_and_pixels(np.zeros((0, 8)))
        assert model_px.shape == (0, 3)
        assert pixels.shape == (0, 3, len(BLOB_POINTS), 2)
        assert ev(np.zeros((0, 8))).shape == (0,)

    def test_views_render_as_naive(self, make):
        from mmocap.evaluators.naive import NaiveEvaluator

        cameras = RIGS["front-side-near"]
        ev, naive = make(), NaiveEvaluator()
        ev.setup(BlobBody(), cameras, empty_masks(cameras))
        naive.setup(BlobBody(), cameras, empty_masks(cameras))
        for x in test_poses()[[0, 5]]:  # whole, partly outside the front view
            for c in range(len(cameras)):
                np.testing.assert_array_equal(ev.render(x, c), naive.render(x, c))

    def test_wholly_outside_empty_and_full_foreground(self, make):
        cameras = RIGS["front-side-near"][:2]
        away = TRUE_POSE + np.r_[-2000.0, 0, 0, np.zeros(5)]  # out of FRONT, in SIDE
        ev = make()
        ev.setup(BlobBody(), cameras, empty_masks(cameras))
        model_px, overlap_px = ev.counts(np.stack([TRUE_POSE, away]))
        assert model_px[1, 0] == 0
        assert model_px[1, 1] > 0
        assert not overlap_px.any()
        np.testing.assert_array_equal(ev(np.stack([TRUE_POSE, away])), [1.0, 0.5])
        ev.setup(BlobBody(), cameras, [np.ones((cam.height, cam.width), bool) for cam in cameras])
        model_px, overlap_px = ev.counts(np.stack([TRUE_POSE, away]))
        np.testing.assert_array_equal(overlap_px, model_px)

    def test_population_of_one_and_of_zero(self, make):
        ev = make()
        ev.setup(BlobBody(), [FRONT], masks("front-side-near", "true")[:1])
        assert ev(TRUE_POSE[None]).tolist() == [0.0]
        assert ev(np.zeros((0, 8))).shape == (0,)
        assert ev.counts(np.zeros((0, 8)))[0].shape == (0, 1)

    @pytest.mark.parametrize("side", [1, 2, 5, 40])
    def test_patch_at_the_documented_pixels_and_image_border(self, make, side):
        """A lone vertex at (100.3, 50.7) covers cx-(s-1)//2 .. cx+s//2 around (100, 51)."""
        cam = Camera.look_at("point", (0, 0, -1000), (0, 0, 0), 500.0, 200, 120)
        ev = make(patch_scale=(side - 0.5) / (500.0 * 2.0 / 1000))  # patch side exactly `side`
        ev.setup(PointBody(ev.patch_scale), [cam], empty_masks([cam]))
        x = np.array([-1.6, 17.6, 0.0])
        image = ev.render(x, 0)
        rows, cols = np.nonzero(image)
        assert (cols.min(), cols.max()) == (100 - (side - 1) // 2, 100 + side // 2)
        assert (rows.min(), rows.max()) == (max(51 - (side - 1) // 2, 0), min(51 + side // 2, 119))
        # one pixel left of the image, then far outside each border
        for shift, expected in ((202.0, min(side // 2, 200)), (5000.0, 0), (-5000.0, 0)):
            X = np.stack([x + np.r_[shift, 0, 0], x + np.r_[0, shift, 0]])
            model_px, _ = ev.counts(X)
            assert model_px[0, 0] == expected * (rows.max() - rows.min() + 1)

    def test_nan_pose_is_an_error_naming_the_row(self, make):
        ev = make()
        ev.setup(BlobBody(), [FRONT], empty_masks([FRONT]))
        X = np.repeat(TRUE_POSE[None], 3, axis=0)
        X[2, 4] = np.nan
        with pytest.raises(ValueError, match="row 2"):
            ev(X)
