"""Holistic and hierarchical strategies: search boxes, partitions, budgets, config errors."""
import numpy as np
import pytest

from mmocap.body.model import BodyModel
from mmocap.body.skeleton import JOINTS, N_FULL, parameter_index
from mmocap.errors import ConfigError
from mmocap.optimizers.cmaes import CMAES
from mmocap.stages.tracking import DEFAULT_STEPS, START_EVALUATIONS, Hierarchical, Holistic


@pytest.fixture(scope="module")
def bodies():
    return {dof: BodyModel("S1", dof=dof) for dof in (39, 28)}


class Recorder:
    """A quadratic 'fitness' around a target pose that records every evaluated batch."""

    def __init__(self, target):
        self.target = target
        self.batches = []

    def __call__(self, X):
        self.batches.append(X.copy())
        return np.sum((X - self.target) ** 2 / np.where(np.arange(N_FULL) < 3, 1e4, 1.0), axis=1)


def test_holistic_searches_every_active_dof_in_the_box(bodies):
    body = bodies[39]
    x_prev = body.rest_pose()
    target = x_prev.copy()
    target[parameter_index("LKnee.rx")] += 0.3
    f = Recorder(target)
    x, fitness, used = Holistic().estimate(body, x_prev, f, CMAES(sigma0=0.3), 1500,
                                           np.random.default_rng(0))
    X = np.concatenate(f.batches)
    assert used == len(X) == 1500
    moved = np.any(X != x_prev, axis=0)
    assert np.array_equal(moved, body.mask)  # every active DOF searched, nothing else
    radius = np.where(np.arange(N_FULL) < 3, 100.0, 0.5)
    assert np.all(np.abs(X - x_prev) <= radius + 1e-9)
    assert np.all((X >= body.lower - 1e-9) & (X <= body.upper + 1e-9))
    assert abs(x[parameter_index("LKnee.rx")] - target[parameter_index("LKnee.rx")]) < 0.1


def test_hierarchical_follows_the_steps_in_order_with_the_documented_budget(bodies):
    body = bodies[39]
    x_prev = body.rest_pose()
    target = x_prev + np.where(body.mask, 0.05, 0.0)
    f = Recorder(target)
    strategy = Hierarchical()
    x, _, used = strategy.estimate(body, x_prev, f, CMAES(sigma0=0.3), 1500, np.random.default_rng(0))
    groups = strategy.step_groups(body)
    budgets = strategy.budgets(groups, 1500 - START_EVALUATIONS)
    assert sum(budgets) + START_EVALUATIONS == used == 1500
    np.testing.assert_array_equal(f.batches[0], x_prev[None])  # the start pose, evaluated first
    # each batch changes exactly the parameters of one step, the steps in order
    changed = [set(np.flatnonzero(np.any(B != B[0], axis=0))) for B in f.batches]
    step_of = {int(i): k for k, step in enumerate(groups) for g in step for i in g}
    order = [max(step_of[i] for i in c) for c in changed if c]
    assert order == sorted(order)
    # 0.05 rad and 0 mm from the target at the start; over seeds 0-7 the RMS rotation error
    # ends at 0.0054-0.0080 rad and the worst translation at 0.65-2.4 mm
    error = np.abs(x - target)
    rotation_rms = np.sqrt(np.mean(error[3:][body.mask[3:]] ** 2))
    assert error[:3].max() < 5 and rotation_rms < 0.015


def test_budget_split_is_proportional_to_dof(bodies):
    strategy = Hierarchical()
    groups = strategy.step_groups(bodies[39])
    assert [sum(len(g) for g in step) for step in groups] == [6, 9, 6, 6, 6, 6]
    assert strategy.budgets(groups, 1500) == [231, 347, 231, 231, 230, 230]
    assert sum(strategy.budgets(groups, 97)) == 97


def test_partitions_reach_the_optimiser(bodies):
    class Spy(CMAES):
        def setup(self, space, rng):
            self.space = space
            super().setup(space, rng)

    spy = Spy()
    body = bodies[39]
    Holistic().estimate(body, body.rest_pose(), Recorder(body.rest_pose()), spy, 100,
                        np.random.default_rng(0))
    sizes = [len(p) for p in spy.space.partitions]
    assert sizes == [6, 9, 6, 6, 6, 6]
    assert np.array_equal(np.concatenate(spy.space.partitions), np.arange(39))


def test_custom_twelve_step_hierarchy(bodies):
    steps = [["Root"], ["BottomSpine"], ["UpperSpine", "Neck"], ["LShoulder"], ["LElbow", "LWrist"],
             ["RShoulder"], ["RElbow", "RWrist"], ["LHip"], ["LKnee", "LAnkle"], ["RHip"],
             ["RKnee", "RAnkle"]]
    strategy = Hierarchical(steps=steps)
    assert len(strategy.step_groups(bodies[39])) == 11


def test_bad_steps_are_config_errors(bodies):
    with pytest.raises(ConfigError, match="unknown joint.*LToe"):
        Hierarchical(steps=[list(s) for s in DEFAULT_STEPS] + [["LToe"]])
    with pytest.raises(ConfigError, match="repeated \\['Neck'\\]"):
        Hierarchical(steps=[list(s) for s in DEFAULT_STEPS] + [["Neck"]])
    with pytest.raises(ConfigError, match="missing \\['RHip', 'RKnee', 'RAnkle'\\]"):
        Hierarchical(steps=DEFAULT_STEPS[:5])
    # the wrists have no DOF in the 28-DOF model: a step of only wrists cannot be searched
    steps = [["Root"], ["BottomSpine", "UpperSpine", "Neck"], ["LShoulder", "LElbow"],
             ["LWrist", "RWrist"], ["RShoulder", "RElbow"], list(DEFAULT_STEPS[4]), list(DEFAULT_STEPS[5])]
    Hierarchical(steps=steps).step_groups(bodies[39])
    with pytest.raises(ConfigError, match="step 4 \\(LWrist, RWrist\\) has no degree of freedom in the 28-DOF"):
        Hierarchical(steps=steps).step_groups(bodies[28])
    # holistic search uses the steps only as partitions: the wrists' step is no partition
    (partitions, budget), = Holistic(steps=steps).plan(bodies[28], 100)
    assert len(partitions) == 6 and sum(len(p) for p in partitions) == 28 and budget == 100
    assert set(JOINTS) == {j for s in DEFAULT_STEPS for j in s}


def test_budget_below_one_population_is_a_config_error(bodies):
    body = bodies[39]
    with pytest.raises(ConfigError, match=r"tracking.evaluations=5 gives step 1 \(Root\) 1 "
                                          r"evaluations but optimizer 'cmaes' needs at least 9"):
        Hierarchical().estimate(body, body.rest_pose(), Recorder(body.rest_pose()), CMAES(), 5,
                                np.random.default_rng(0))
    with pytest.raises(ConfigError, match="gives the frame 13 evaluations.*at least 14 for 39"):
        Holistic().check(body, CMAES(), 14)  # one of the 14 goes to the start pose
    Holistic().check(body, CMAES(), 15)


def test_the_frame_clock_times_the_search_and_the_foreground_apart(bodies, monkeypatch):
    """On a clock that only moves when the foreground is read (5 s, a mask-cache miss) and
    when the evaluator scores a batch (1 ms), a frame's seconds are its search's alone."""
    from types import SimpleNamespace

    from mmocap.stages import tracking

    body = bodies[39]
    clock = [0.0]
    monkeypatch.setattr(tracking.time, "perf_counter", lambda: clock[0])

    class Foreground:
        cameras = []

        def masks(self, frame):
            clock[0] += 5.0
            return []

    class Evaluator(Recorder):
        def setup(self, body, cameras, masks):
            pass

        def __call__(self, X):
            clock[0] += 0.001
            return super().__call__(X)

    evaluator = Evaluator(body.rest_pose())
    sequence = SimpleNamespace(n_frames=2, x0=body.rest_pose())
    results = tracking.track(sequence, body, Foreground(), evaluator, CMAES(), Holistic(), evaluations=100, seed=0)
    for result in results:
        assert result.foreground_seconds == pytest.approx(5.0)
        assert result.seconds == pytest.approx(0.001 * len(evaluator.batches) / 2)
