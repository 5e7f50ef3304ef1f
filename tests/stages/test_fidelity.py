from types import SimpleNamespace

import numpy as np
import pytest

from mmocap.analysis.results import run_key
from mmocap.body.model import BodyModel
from mmocap.camera import Camera
from mmocap.errors import ConfigError
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.optimizers.cmaes import CMAES
from mmocap.stages import tracking
from mmocap.stages.fidelity import Fidelity, check_levels, shrunk_mask
from mmocap.stages.tracking import Holistic


def test_a_shrunk_mask_pixel_is_foreground_when_most_of_it_is():
    mask = np.zeros((8, 8), bool)
    mask[:4, :4] = True  # a whole 4x4 block
    mask[4:, 4:] = np.arange(16).reshape(4, 4) < 9  # 9 of 16 pixels
    mask[:4, 4:] = np.arange(16).reshape(4, 4) < 8  # 8 of 16: not more than half
    np.testing.assert_array_equal(shrunk_mask(mask, 2, 2), [[True, False], [False, True]])


@pytest.mark.parametrize(
    ("levels", "message"),
    [
        ([{"scale": 0, "evaluations": 100}], r"fidelity.levels\[0\].scale must be a number in \(0, 1\]"),
        ([{"scale": 1.5, "evaluations": 100}], r"fidelity.levels\[0\].scale must be a number in \(0, 1\]"),
        ([{"scale": 0.5, "evaluations": 100}, {"scale": 0.5}], r"fidelity.levels\[1\] needs evaluations"),
        ([{"scale": 0.5, "evaluations": 100, "vertices": 500}], r"levels\[0\].vertices must be an integer in \[1000"),
        ([{"scale": 0.5, "evaluations": 100.5}], r"fidelity.levels\[0\].evaluations must be an integer"),
        (
            [{"scale": 0.5, "evaluations": 100, "resolution": 2}],
            r"fidelity.levels\[0\] has unknown key\(s\) resolution",
        ),
        ("0.5", "fidelity.levels must be a list"),
    ],
)
def test_bad_levels_are_config_errors_naming_the_key(levels, message):
    with pytest.raises(ConfigError, match=message):
        check_levels(levels)


def test_no_levels_leave_the_run_key_as_it_was():
    from omegaconf import OmegaConf

    base = OmegaConf.create({"seed": 0, "tracking": {"evaluations": 1500}})
    exact = OmegaConf.merge(base, {"fidelity": {"_target_": "mmocap.stages.fidelity.Fidelity", "levels": []}})
    assert run_key(exact) == run_key(base)
    cheap = OmegaConf.merge(exact, {"fidelity": {"levels": [{"scale": 0.5, "vertices": 3000, "evaluations": 500}]}})
    assert run_key(cheap) != run_key(base)


@pytest.fixture(scope="module")
def scene():
    """Two cameras watching S1 in a bent pose, its masks rendered with a denser body than
    the tracker's (27393 against 13695 skin samples)."""
    cameras = [
        Camera.look_at("C1", [3500.0, -2500.0, 1600.0], [0.0, 0.0, 900.0], 500.0, 320, 240),
        Camera.look_at("C2", [-2800.0, -3000.0, 1400.0], [0.0, 0.0, 900.0], 500.0, 320, 240),
    ]
    truth_body, body = BodyModel("S1", vertices=27393), BodyModel("S1", vertices=13695)
    truth = body.rest_pose() + np.where(body.mask, 0.12, 0.0) * np.sin(np.arange(51))
    renderer = NumpyEvaluator()
    renderer.setup(truth_body, cameras, [np.zeros((c.height, c.width), bool) for c in cameras])
    masks = [renderer.render(truth, c) for c in range(len(cameras))]
    assert all(0.01 < m.mean() < 0.5 for m in masks)  # the person is in view
    return SimpleNamespace(cameras=cameras, masks=masks, body=body, truth=truth)


def track_one_frame(scene, evaluations, fidelity=None):
    evaluator = NumpyEvaluator()
    sequence = SimpleNamespace(n_frames=1, x0=scene.body.rest_pose(), root="scene")
    foreground = SimpleNamespace(cameras=scene.cameras, masks=lambda frame: scene.masks)
    [result] = tracking.track(
        sequence,
        scene.body,
        foreground,
        evaluator,
        CMAES(),
        Holistic(),
        evaluations=evaluations,
        seed=0,
        fidelity=fidelity,
    )
    evaluator.setup(scene.body, scene.cameras, scene.masks)
    return result, evaluator


@pytest.mark.parametrize("carry", [True, False], ids=["carried", "restarted"])
def test_the_cheap_levels_lead_the_exact_search_which_scores_the_frame(scene, carry):
    fidelity = Fidelity([{"scale": 0.5, "vertices": 3000, "evaluations": 600}], evaluator=NumpyEvaluator, carry=carry)
    result, exact = track_one_frame(scene, 150, fidelity)
    assert result.evaluations == 600 + 150
    assert result.fitness == exact(result.pose[None])[0]  # the frame's fitness is the exact one
    level = fidelity._evaluators[0]
    assert level.body.n_vertices == 3000
    assert [c.width for c in level.cameras] == [160, 160]
    assert [m.shape for m in level.foreground] == [(120, 160), (120, 160)]
    # the trace counts the cheap evaluations and records the exact ones after them (carried:
    # from the first call that begins after the 600th evaluation)
    assert 600 < result.trace[0, 0] <= 600 + CMAES().population_size(39) if carry else result.trace[0, 0] == 601
    assert result.trace[-1].tolist() == [750, result.fitness]
    # and they pay: the exact search from their pose ends better than one from the start
    alone, _ = track_one_frame(scene, 150)
    assert result.fitness < alone.fitness
    fidelity.close()


class Counting(NumpyEvaluator):
    """The NumPy evaluator, noting the size of each call in ``sizes``."""

    def __call__(self, X):
        self.sizes = [*getattr(self, "sizes", []), len(X)]
        return super().__call__(X)


def test_a_level_may_search_with_its_own_optimiser_settings(scene):
    fidelity = Fidelity(
        [{"scale": 0.5, "vertices": 3000, "evaluations": 301, "optimizer": {"popsize": 30}}],
        evaluator=Counting,
        optimizer=lambda **settings: CMAES(**settings),
        carry=False,
    )
    result, _ = track_one_frame(scene, 150, fidelity)
    assert result.evaluations == 301 + 150
    assert fidelity._evaluators[0].sizes == [1] + [30] * 10  # the start, then generations of 30
    with pytest.raises(ConfigError, match="need an optimizer factory"):
        Fidelity(
            [{"scale": 0.5, "evaluations": 100, "optimizer": {"popsize": 30}}], evaluator=NumpyEvaluator, carry=False
        )
    with pytest.raises(ConfigError, match=r"levels\[0\].optimizer needs fidelity.carry=false"):
        Fidelity(
            [{"scale": 0.5, "evaluations": 100, "optimizer": {"popsize": 30}}],
            evaluator=NumpyEvaluator,
            optimizer=CMAES,
        )
    with pytest.raises(ConfigError, match=r"levels\[0\].optimizer must be a mapping"):
        check_levels([{"scale": 0.5, "evaluations": 100, "optimizer": 30}])


def test_carrying_on_needs_the_holistic_strategy():
    from mmocap.stages.tracking import Hierarchical

    fidelity = Fidelity([{"scale": 0.5, "evaluations": 100}], evaluator=NumpyEvaluator)
    fidelity.check(Holistic())
    with pytest.raises(ConfigError, match="fidelity.carry=true needs strategy=holistic .* set fidelity.carry=false"):
        fidelity.check(Hierarchical())
    Fidelity([{"scale": 0.5, "evaluations": 100}], evaluator=NumpyEvaluator, carry=False).check(Hierarchical())
    with pytest.raises(ConfigError, match="fidelity.carry must be true or false"):
        Fidelity([], carry="yes")


def test_warming_up_evaluates_the_start_pose_once_at_every_level(scene):
    fidelity = Fidelity(
        [{"scale": 0.5, "vertices": 3000, "evaluations": 100}, {"scale": 0.25, "evaluations": 100}], evaluator=Counting
    )
    fidelity.warm_up(scene.body, scene.cameras, scene.masks, scene.body.rest_pose())
    assert [level.sizes for level in fidelity._evaluators] == [[1], [1]]
    assert [level.body.n_vertices for level in fidelity._evaluators] == [3000, 13695]
    assert [c.width for c in fidelity._evaluators[1].cameras] == [80, 80]
    fidelity.close()
    Fidelity().warm_up(scene.body, scene.cameras, scene.masks, scene.body.rest_pose())  # no levels: nothing to do
