"""The keypoint term: its robust losses, its normalisation, its inputs checked, and the
hybrid fitness of the evaluators (their equality across backends is the conformance suite's)."""

import numpy as np
import pytest

from mmocap import registry
from mmocap.body.keypoints import MODEL_POINTS, model_points, posed_points
from mmocap.errors import ConfigError, DataError
from mmocap.evaluators.keypoint_term import Keypoints, KeypointTerm, person_height_px
from mmocap.testing.scene import Scene

TERM = KeypointTerm(1.0, "geman_mcclure", 0.05)


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene(2000, cameras=3)


def observed_at(scene: Scene, pose: np.ndarray) -> np.ndarray:
    """(C, 17, 3) the model points of ``pose`` projected into each camera, confidence 1."""
    joint, rest = model_points(scene.body, MODEL_POINTS)
    world = posed_points(scene.body, pose[None], joint, rest)[0]
    return np.stack([np.c_[cam.project(world), np.ones(len(world))] for cam in scene.cameras])


def test_geman_mcclure_is_bounded_and_huber_grows_linearly():
    r = np.array([0.0, 1.0, 10.0, 1e6])
    gm = KeypointTerm(1.0, "geman_mcclure", 0.05).rho(r)
    np.testing.assert_allclose(gm[:2], [0.0, 0.5])
    assert 0.999 < gm[-1] < 1.0
    huber = KeypointTerm(1.0, "huber", 0.05).rho(r)
    np.testing.assert_allclose(huber[:3], [0.0, 0.5, 9.5])


def test_the_term_is_in_person_heights_so_image_scale_does_not_change_it():
    pixels = np.array([[[[110.0, 100.0], [200.0, 230.0]]]], np.float32)  # (1, 1, 2, 2)
    observed = np.array([[[100.0, 100.0, 1.0], [200.0, 200.0, 0.5]]])
    small = TERM.value(pixels, observed, np.array([400.0]))
    big = TERM.value(pixels * 2, observed * [2, 2, 1], np.array([800.0]))
    np.testing.assert_allclose(small, big)
    # by hand: r = 10 / 20 and 30 / 20, weights 1 and 0.5
    expected = (0.25 / 1.25 + 0.5 * (2.25 / 3.25)) / 1.5
    np.testing.assert_allclose(small, [expected])


def test_unseen_keypoints_count_nothing_and_a_point_behind_the_camera_counts_as_one_height_away():
    pixels = np.array([[[[np.nan, np.nan], [0.0, 0.0]]]], np.float32)
    observed = np.array([[[5.0, 5.0, 1.0], [50.0, 50.0, 0.0]]])
    behind = TERM.value(pixels, observed, np.array([100.0]))
    np.testing.assert_allclose(behind, TERM.rho(np.array([1 / TERM.scale])))
    assert TERM.value(pixels, observed * [1, 1, 0], np.array([100.0]))[0] == 0.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"weight": -1.0}, "keypoints.weight"),
        ({"scale": 0.0}, "keypoints.scale"),
        ({"loss": "cauchy"}, "keypoints.loss must be one of geman_mcclure, huber"),
    ],
)
def test_bad_settings_name_their_key(kwargs, message):
    settings = {"weight": 1.0, "loss": "geman_mcclure", "scale": 0.05, **kwargs}
    with pytest.raises(ConfigError, match=message):
        KeypointTerm(**settings)


def test_keypoints_refuse_a_confidence_outside_0_1_and_nan_where_confident():
    points = ("Root", "Nose")
    good = np.array([[[1.0, 2.0, 1.0], [np.nan, np.nan, 0.0]]])
    Keypoints(points, np.zeros((2, 3)), good, TERM)
    with pytest.raises(DataError, match=r"outside \[0, 1\]"):
        Keypoints(points, np.zeros((2, 3)), good * [1, 1, 1.5], TERM)
    with pytest.raises(DataError, match="NaN"):
        Keypoints(points, np.zeros((2, 3)), np.array([[[np.nan, 2.0, 1.0], [0, 0, 0]]]), TERM)
    with pytest.raises(DataError, match=r"\(cameras, 2, 3\)"):
        Keypoints(points, np.zeros((2, 3)), np.zeros((1, 3, 3)), TERM)


def test_shrunk_cameras_see_the_keypoints_where_their_pixels_are(scene):
    observed = observed_at(scene, scene.pose)
    keypoints = Keypoints(MODEL_POINTS, np.zeros((17, 3)), observed, TERM)
    small = [cam.shrunk(0.5) for cam in scene.cameras]
    joint, rest = model_points(scene.body, MODEL_POINTS)
    world = posed_points(scene.body, scene.pose[None], joint, rest)[0]
    moved = keypoints.on(scene.cameras, small).observed
    for c, cam in enumerate(small):
        np.testing.assert_allclose(moved[c, :, :2], cam.project(world), atol=1e-9)


def test_the_person_height_is_the_masks_bounding_box():
    mask = np.zeros((50, 40), bool)
    mask[10:35, 5:9] = True
    assert person_height_px(mask) == 25.0
    assert person_height_px(np.zeros((50, 40), bool)) == 50.0


def test_the_hybrid_fitness_is_least_at_the_true_pose_and_grows_with_a_wrong_arm(scene):
    observed = observed_at(scene, scene.pose)
    keypoints = Keypoints(MODEL_POINTS, np.zeros((17, 3)), observed, TERM)
    wrong = scene.pose.copy()
    wrong[3 + 3 * 7 + 1] += 1.0  # the right elbow bent by a radian more
    with registry.make_evaluator("numpy") as evaluator:
        evaluator.setup(scene.body, scene.cameras, scene.foreground)
        silhouettes = evaluator(np.stack([scene.pose, wrong]))
        evaluator.setup(scene.body, scene.cameras, scene.foreground, keypoints)
        hybrid = evaluator(np.stack([scene.pose, wrong]))
        _, _, pixels = evaluator.counts_and_pixels(scene.pose[None])
    assert hybrid[0] == pytest.approx(silhouettes[0], abs=1e-9)  # the true pose: no keypoint cost
    assert hybrid[1] - silhouettes[1] > 0.01
    np.testing.assert_allclose(pixels[0], observed[..., :2], atol=1e-3)  # the float32 rule: near the float64 projection


def test_without_keypoints_the_fitness_is_the_silhouettes_and_no_pixels_come_back(scene):
    with registry.make_evaluator("numpy") as evaluator:
        evaluator.setup(scene.body, scene.cameras, scene.foreground)
        model_px, overlap_px, pixels = evaluator.counts_and_pixels(scene.pose[None])
    assert pixels.shape == (1, 3, 0, 2)
    assert model_px.shape == overlap_px.shape == (1, 3)
