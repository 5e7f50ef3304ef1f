"""The automatic start: rays, visual hull and the search for the first pose and body size."""

import numpy as np
import pytest

from mmocap.body.model import BodyModel
from mmocap.camera import Camera
from mmocap.data.sequence import Sequence
from mmocap.errors import ConfigError, DataError
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.optimizers.cmaes import CMAES
from mmocap.stages.initialisation import (
    ROOT_YAW,
    AutoStart,
    nearest_point_to_rays,
    search_each_limb,
    silhouette_rays,
    visual_hull,
)
from mmocap.stages.tracking import Holistic

CENTRE = np.array([300.0, 900.0, -200.0])  # mm


def ring_of_cameras(count: int = 4, size=(320, 240)) -> list[Camera]:
    """Ideal cameras 4 m around CENTRE, 1.5 m up, looking at it."""
    cameras = []
    for k in range(count):
        angle = 2 * np.pi * k / count
        eye = CENTRE + [4000 * np.cos(angle), 600, 4000 * np.sin(angle)]
        cameras.append(Camera.look_at(f"K{k}", eye, CENTRE, 300.0, *size))
    return cameras


def sphere_masks(cameras, centre, radius_mm) -> list[np.ndarray]:
    """(H, W) bool images of a ball: pixels whose ray passes within ``radius_mm`` of ``centre``."""
    masks = []
    for camera in cameras:
        rows, cols = np.mgrid[0 : camera.height, 0 : camera.width]
        pixels = np.stack([cols, rows, np.ones_like(cols)], axis=-1).reshape(-1, 3).astype(float)
        rays = pixels @ np.linalg.inv(camera.K).T @ camera.R
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        to_centre = centre - camera.centre
        distance = np.linalg.norm(to_centre - (rays @ to_centre)[:, None] * rays, axis=1)
        masks.append((distance < radius_mm).reshape(camera.height, camera.width))
    return masks


def test_rays_through_the_silhouettes_of_a_ball_meet_at_its_centre():
    cameras = ring_of_cameras()
    point = nearest_point_to_rays(*silhouette_rays(cameras, sphere_masks(cameras, CENTRE, 250)))
    assert np.linalg.norm(point - CENTRE) < 10


def test_fewer_than_two_silhouettes_cannot_place_anybody():
    cameras = ring_of_cameras(2)
    masks = sphere_masks(cameras, CENTRE, 250)
    masks[1][:] = False
    with pytest.raises(DataError, match="at least two cameras"):
        nearest_point_to_rays(*silhouette_rays(cameras, masks))


def test_the_visual_hull_of_a_ball_is_about_the_ball():
    cameras = ring_of_cameras(6)
    hull = visual_hull(cameras, sphere_masks(cameras, CENTRE, 300), CENTRE - 600, CENTRE + 600, voxel_mm=20)
    distance = np.linalg.norm(hull - CENTRE, axis=1)
    assert distance.max() < 300 * 1.25  # six views carve a ball to within a quarter of its radius
    inner = visual_hull(cameras, sphere_masks(cameras, CENTRE, 300), CENTRE - 160, CENTRE + 160, voxel_mm=20)
    assert len(inner) == 16**3  # a cube inside the ball (corners at 277 mm): every voxel kept
    assert abs(hull[:, 1].max() - hull[:, 1].min() - 600) < 60


@pytest.fixture(scope="module")
def first_frame(tiny_sequence):
    """The tiny sequence's cameras (ideal) and frame-0 true silhouettes, undistorted."""
    sequence = Sequence.open(tiny_sequence)
    cameras = [c.ideal() for c in sequence.cameras]
    masks = [c.undistort_mask(sequence.silhouette(0, c)) for c in sequence.cameras]
    return sequence, cameras, masks


def test_the_hull_measures_the_person_standing_in_the_sequence(first_frame):
    sequence, cameras, masks = first_frame
    truth = BodyModel("S1", vertices=1000)
    centre, height, floor_y = AutoStart().measure(cameras, masks)
    assert abs(height - truth.subject.height_mm) < 150  # three views, 320x240: a coarse hull
    assert abs(floor_y) < 80  # the synthetic floor is y = 0
    assert np.linalg.norm((centre - sequence.x0[:3])[[0, 2]]) < 150


def test_the_search_finds_the_heading_and_beats_the_rest_pose(first_frame):
    sequence, cameras, masks = first_frame
    body = BodyModel("S1", vertices=1000)
    evaluator = NumpyEvaluator(patch_scale=1.5)
    start = AutoStart(
        headings=8,
        candidates=2,
        evaluations=300,
        limb_evaluations=150,
        rounds=1,
        girth_steps=[],
        height_steps_mm=[],
        limb_samples=50,
        limb_restarts=1,
    )
    found = start.find(body, cameras, masks, evaluator, CMAES(), Holistic(), np.random.default_rng(0), fit_girth=False)
    heading_error = np.angle(np.exp(1j * (found.pose[ROOT_YAW] - sequence.x0[ROOT_YAW])))
    assert abs(heading_error) < np.radians(35)
    evaluator.setup(found.body, cameras, masks)
    placed = found.body.rest_pose()
    placed[[0, 2]] = found.pose[[0, 2]]
    assert found.fitness < evaluator(placed[None])[0]
    assert found.fitness == pytest.approx(evaluator(found.pose[None])[0])
    assert found.evaluations > 8
    assert found.seconds > 0
    # the body is the visual hull's height plus the offset that scored best
    offset = found.body.subject.height_mm - found.height_mm
    assert found.body.subject.girth == 1.0
    assert min(abs(offset - o) for o in start.hull_height_offsets_mm) < 1e-6
    assert set(found.summary()) >= {"method", "seconds", "evaluations", "body_height_mm", "body_girth"}


def test_random_limb_poses_bring_back_an_arm_that_a_local_search_misses(first_frame):
    """The right arm starts swung to the other end of its range; with 200 evaluations per
    limb a search from there alone leaves the arm's markers more than 400 mm off, 400 random
    poses of the limb first bring them within 300 mm."""
    sequence, cameras, masks = first_frame
    body = BodyModel("S1", vertices=1000)
    arm = np.concatenate(Holistic().step_groups(body)[3])
    wrong = sequence.x0.copy()
    wrong[arm] = np.where(
        sequence.x0[arm] - body.lower[arm] < body.upper[arm] - sequence.x0[arm], body.upper[arm], body.lower[arm]
    )
    with NumpyEvaluator(patch_scale=1.5) as evaluator:
        evaluator.setup(body, cameras, masks)
        start = float(evaluator(wrong[None])[0])
        errors = {}
        for samples in (0, 400):
            x, fitness, used = search_each_limb(
                Holistic(),
                body,
                wrong,
                start,
                evaluator,
                CMAES(),
                200,
                np.random.default_rng(1),
                samples=samples,
                restarts=1,
            )
            assert fitness <= start
            assert used <= 5 * (200 + samples)
            errors[samples] = np.linalg.norm(body.markers(x[None]) - body.markers(sequence.x0[None]), axis=-1).max()
    assert errors[400] < 300, errors  # mm
    assert errors[0] > 400, errors  # mm, the arm's worst marker (6 seeds: 54-239 mm)


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("mode", "always"),
        ("headings", 0),
        ("candidates", 13),
        ("girth_steps", [2.0]),
        ("limb_restarts", -1),
        ("voxel_mm", 100),
        ("rounds", 1.5),
        ("hull_height_offsets_mm", []),
    ],
)
def test_a_bad_setting_names_its_key(key, value):
    with pytest.raises(ConfigError, match=f"start.{key}"):
        AutoStart(**{key: value})


def test_the_start_searches_full_hd_cameras_shrunk_to_max_image_px():
    start = AutoStart(max_image_px=640)
    big = Camera.look_at("HD", [3000.0, 1500.0, 3000.0], [0.0, 900.0, 0.0], 1700.0, 1920, 1080)
    small = Camera.look_at("VGA", [-3000.0, 1500.0, 3000.0], [0.0, 900.0, 0.0], 600.0, 640, 480)
    mask = np.zeros((1080, 1920), bool)
    mask[300:900, 900:1050] = True
    cameras, masks = start.reduced([big, small], [mask, np.ones((480, 640), bool)])
    assert (cameras[0].width, cameras[0].height) == (640, 360)
    assert masks[0].shape == (360, 640)
    assert masks[0].sum() == pytest.approx(mask.sum() / 9, rel=0.02)
    assert cameras[1] is small  # already within the limit
    point = np.array([[0.0, 900.0, 0.0]])
    np.testing.assert_allclose(cameras[0].project(point), (big.project(point) + 0.5) / 3 - 0.5, atol=1e-9)
    assert AutoStart(max_image_px=None).reduced([big], [mask])[0][0] is big
