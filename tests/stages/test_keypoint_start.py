"""The start from keypoints: triangulation with RANSAC, the fit to the triangulated points,
and AutoStart choosing it over the silhouette search."""

import functools
import time

import numpy as np
import pytest

from mmocap.body.keypoints import MODEL_POINTS, model_points, posed_points
from mmocap.body.model import BodyModel
from mmocap.errors import ConfigError, DataError
from mmocap.evaluators.keypoint_term import Keypoints, KeypointTerm
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.optimizers.cmaes import CMAES
from mmocap.stages.initialisation import ROOT_YAW, AutoStart
from mmocap.stages.keypoint_start import fit_keypoints, locates_pelvis_and_heading, triangulate
from mmocap.stages.tracking import Holistic
from mmocap.testing.scene import Scene

NOISE_PX = 2.0
INLIER_PX = 15.0
#: the person seen: another body than the tracker's (S1, 1780 mm, girth 1)
TRUTH = {"height_mm": 1690.0, "girth": 1.1}


@functools.cache
def cameras():
    """Four 640x480 ideal cameras on the synthetic ring."""
    return Scene(1000, cameras=4).cameras


@functools.cache
def person(yaw: float, seed: int = 3, vertices: int = 1000):
    """The truth body (``vertices`` skin samples), a random pose of it (0.3 rad on every
    joint angle, within the limits) turned to ``yaw`` (rad) at (250, -150) mm, its 640x480
    masks, the (K, 3) mm model points and their (C, K, 3) keypoints projected with
    ``NOISE_PX`` noise (px), confidence 0.9."""
    rng = np.random.default_rng(seed)
    truth = BodyModel(vertices=vertices, **TRUTH)
    scale = np.where(np.arange(51) >= 6, 0.3, 0.0) * truth.mask
    pose = truth.rest_pose() + rng.normal(0.0, 1.0, 51) * scale
    pose[[0, 2]] = 250.0, -150.0
    pose[ROOT_YAW] = yaw
    pose = truth.clip(pose)
    with NumpyEvaluator() as evaluator:
        evaluator.setup(truth, cameras(), [np.zeros((480, 640), bool)] * 4)
        masks = [evaluator.render(pose, c) for c in range(4)]
    points = posed_points(truth, pose[None], *model_points(truth, MODEL_POINTS))[0]
    observed = np.stack(
        [
            np.c_[c.project(points) + rng.normal(0.0, NOISE_PX, (len(points), 2)), np.full(len(points), 0.9)]
            for c in cameras()
        ]
    )
    return truth, pose, masks, points, observed


def swapped(observed: np.ndarray, camera: int, a: str, b: str) -> np.ndarray:
    """``observed`` with the detections of the points ``a`` and ``b`` exchanged in one camera."""
    out = observed.copy()
    i, j = MODEL_POINTS.index(a), MODEL_POINTS.index(b)
    out[camera, [i, j]] = out[camera, [j, i]]
    return out


def keypoints(observed: np.ndarray) -> Keypoints:
    return Keypoints(MODEL_POINTS, np.zeros((len(MODEL_POINTS), 3)), observed, KeypointTerm(weight=1.0))


def marker_error_mm(body, x, truth, pose) -> float:
    return float(np.linalg.norm(body.markers(x[None]) - truth.markers(pose[None]), axis=-1).mean())


def wrapped(angle: float) -> float:
    return float(np.angle(np.exp(1j * angle)))


def test_triangulation_is_exact_on_synthetic_projections():
    rng = np.random.default_rng(0)
    points = rng.uniform([-800, 0, -800], [800, 1900, 800], (20, 3))
    observed = np.stack([np.c_[c.project(points), rng.uniform(0.2, 1.0, len(points))] for c in cameras()])
    observed[1:, 0, 2] = 0.0  # the first point seen by one camera only
    found, inliers = triangulate(cameras(), observed, INLIER_PX)
    assert np.isnan(found[0]).all()
    assert not inliers[:, 0].any()
    np.testing.assert_allclose(found[1:], points[1:], atol=1e-6)  # mm
    assert inliers[:, 1:].all()


def test_ransac_rejects_a_swapped_detection_in_one_of_four_cameras():
    _, _, _, points, observed = person(0.0)
    observed = swapped(observed, 1, "LWrist", "RWrist")
    wrists = [MODEL_POINTS.index("LWrist"), MODEL_POINTS.index("RWrist")]
    found, inliers = triangulate(cameras(), observed, INLIER_PX)
    assert not inliers[1, wrists].any()
    assert inliers.sum() == inliers.size - 2  # every other detection agrees
    error = np.linalg.norm(found - points, axis=1)
    assert error.max() < 40, error  # mm, with 2 px noise
    everyone, _ = triangulate(cameras(), observed, inlier_px=1e6)  # every camera an inlier: least squares
    assert np.linalg.norm(everyone - points, axis=1)[wrists].min() > 100  # mm: the swap pulls the wrists away


@pytest.mark.parametrize("yaw", [0.7, np.pi])
def test_the_fit_recovers_a_pose_and_the_heading_even_facing_away(yaw):
    """A body 90 mm shorter and 10 % thicker than the tracker's, 2 px noise, one swapped pair:
    the height within 40 mm, the heading within 0.15 rad, the markers within 30 mm on
    average (measured on seeds 3-5 at both headings: 1676-1706 mm, within 0.07 rad, 18-25 mm,
    the posed points 7-11 mm from the triangulated ones). Facing away (yaw pi) the
    silhouettes are nearly those of the person facing the cameras, mirrored; the keypoints
    tell left from right."""
    truth, pose, _, _, observed = person(yaw)
    fit = fit_keypoints(
        BodyModel(vertices=1000), cameras(), keypoints(swapped(observed, 1, "LWrist", "RWrist")), INLIER_PX, True
    )
    assert abs(fit.body.subject.height_mm - TRUTH["height_mm"]) < 40
    assert abs(wrapped(fit.pose[ROOT_YAW] - yaw)) < 0.15
    assert marker_error_mm(fit.body, fit.pose, truth, pose) < 30
    assert fit.residual_mm < 20


def test_without_the_height_fitted_the_body_keeps_its_own():
    _, _, _, _, observed = person(np.pi)
    body = BodyModel(vertices=1000)
    fit = fit_keypoints(body, cameras(), keypoints(observed), INLIER_PX, fit_height=False)
    assert fit.body is body


def test_keypoints_that_place_no_pelvis_are_not_used():
    _, _, _, points, _ = person(0.0)
    names = list(MODEL_POINTS)
    assert locates_pelvis_and_heading(names, points)
    without = points.copy()
    without[[names.index(n) for n in ("Root", "LHip")]] = np.nan
    assert not locates_pelvis_and_heading(names, without)  # the pelvis: Root or both hips
    without = points.copy()
    without[[names.index(n) for n in ("LHip", "LShoulder")]] = np.nan
    assert not locates_pelvis_and_heading(names, without)  # no left-right axis


def test_the_start_from_noisy_keypoints_on_640x480_masks():
    """The whole start (shortened budgets: the numpy evaluator) from the keypoints of a
    person facing away, one swapped pair; its time is printed, not asserted."""
    truth, pose, masks, _, observed = person(np.pi)
    body = BodyModel(vertices=1000)
    start = AutoStart(keypoint_evaluations=300, keypoint_limb_evaluations=100, shape_evaluations=100)
    with NumpyEvaluator() as evaluator:
        began = time.perf_counter()
        found = start.find(
            body,
            cameras(),
            masks,
            evaluator,
            CMAES(),
            Holistic(),
            np.random.default_rng(0),
            keypoints=keypoints(swapped(observed, 1, "LWrist", "RWrist")),
        )
        seconds = time.perf_counter() - began
        error = marker_error_mm(found.body, found.pose, truth, pose)
        print(f"start from keypoints: {seconds:.2f} s, {found.evaluations} evaluations, markers {error:.1f} mm off")
        assert found.fitness == pytest.approx(evaluator(found.pose[None])[0])  # the hybrid fitness, left set up
    assert found.summary()["method"] == "keypoints"
    assert abs(wrapped(found.pose[ROOT_YAW] - np.pi)) < 0.15
    assert error < 30  # mm
    assert found.seconds > 0


def test_keypoints_seen_by_one_camera_leave_the_silhouette_search():
    _, _, masks, _, observed = person(0.0)
    observed = observed.copy()
    observed[1:, :, 2] = 0.0
    tiny = dict(headings=2, candidates=1, evaluations=20, limb_evaluations=10, limb_samples=0, limb_restarts=0)
    start = AutoStart(
        **tiny, refined=1, rounds=1, passes=1, girth_steps=[], height_steps_mm=[], hull_height_offsets_mm=[0.0]
    )
    with NumpyEvaluator() as evaluator:
        found = start.find(
            BodyModel(vertices=1000),
            cameras(),
            masks,
            evaluator,
            CMAES(),
            Holistic(),
            np.random.default_rng(0),
            keypoints=keypoints(observed),
        )
        assert evaluator.keypoints is None  # the search's fitness: silhouettes only
    assert found.summary()["method"] == "search"


@pytest.mark.parametrize(
    ("key", "value"), [("keypoint_evaluations", 1), ("keypoint_limb_evaluations", 0.5), ("keypoint_inlier_px", 0)]
)
def test_a_bad_keypoint_setting_names_its_key(key, value):
    with pytest.raises(ConfigError, match=f"start.{key}"):
        AutoStart(**{key: value})


def test_keypoints_of_another_camera_count_are_refused_naming_both_counts():
    _, _, masks, _, observed = person(0.0)
    with pytest.raises(DataError, match="keypoints of 3 cameras for 4 cameras"):
        AutoStart().find(
            BodyModel(vertices=1000),
            cameras(),
            masks,
            NumpyEvaluator(),
            CMAES(),
            Holistic(),
            np.random.default_rng(0),
            keypoints=keypoints(observed[:3]),
        )
