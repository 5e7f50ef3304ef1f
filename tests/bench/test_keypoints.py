"""The keypoint term's cost (mmocap.bench.keypoints): workloads, the scene's keypoints, the table."""

import numpy as np
import pytest

from mmocap import registry
from mmocap.bench.keypoints import WORKLOADS, keypoint_table, parse_workloads, scene_keypoints
from mmocap.errors import ConfigError
from mmocap.evaluators.silhouette import fitness_from_counts
from mmocap.testing.scene import Scene


@pytest.fixture(scope="module")
def small_scene():
    return Scene(2000, cameras=2)


def test_the_default_workloads_are_the_demos_and_canos():
    assert parse_workloads(WORKLOADS) == [(4, 13695), (7, 27393)]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("4-13695", "--workloads must be CAMERAS:VERTICES"),
        ("4:13695:1", "--workloads must be CAMERAS:VERTICES"),
        ("0:13695", "--workloads cameras"),
        ("4:5", "--workloads vertices"),
    ],
)
def test_a_bad_workload_is_a_config_error_naming_the_option(text, message):
    with pytest.raises(ConfigError, match=message):
        parse_workloads(text)


def test_the_scenes_keypoints_are_its_model_points_where_its_pose_puts_them(small_scene):
    keypoints = scene_keypoints(small_scene, weight=0.5)
    assert len(keypoints.points) == 17
    assert keypoints.observed.shape == (2, 17, 3)
    assert keypoints.term.weight == 0.5
    assert (keypoints.observed[..., 2] == 1).all()  # every point in front of both cameras
    with registry.make_evaluator("numpy") as ev:
        ev.setup(small_scene.body, small_scene.cameras, small_scene.foreground, keypoints)
        _, _, pixels = ev.counts_and_pixels(small_scene.pose[None])
        np.testing.assert_array_equal(pixels[0], keypoints.observed[..., :2])
        # the pose itself matches perfectly; another one costs more than its silhouettes
        X = np.stack([small_scene.pose, small_scene.candidates(1)[0]])
        silhouette = fitness_from_counts(*ev.counts(X), ev.fg_px)
        fitness = ev(X)
        assert fitness[0] == 0.0
        assert fitness[1] > silhouette[1] > 0


def test_the_table_times_each_backend_off_and_on_at_cmaes_population_and_the_given_one(small_scene):
    with registry.make_evaluator("numpy") as ev:
        table = keypoint_table({"numpy": ev}, [(2, 2000)], population=6, repeats=1, candidates=12)
    assert list(table.population) == [14, 6]  # lambda of CMA-ES for 39 degrees of freedom
    assert list(table.cameras) == [2, 2]
    assert list(table.vertices) == [2000, 2000]
    assert (table.us_per_evaluation_off > 0).all()
    assert (table.us_per_evaluation_on > 0).all()
    np.testing.assert_allclose(table.ratio_on_to_off, table.us_per_evaluation_on / table.us_per_evaluation_off)
