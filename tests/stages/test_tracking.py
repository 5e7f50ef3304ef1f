"""Holistic and hierarchical strategies: search boxes, partitions, budgets, config errors."""

import numpy as np
import pytest

from mmocap.body.model import BodyModel
from mmocap.body.skeleton import JOINTS, N_FULL, parameter_index
from mmocap.errors import ConfigError
from mmocap.optimizers.cmaes import CMAES
from mmocap.stages.recovery import Recovery
from mmocap.stages.tracking import DEFAULT_STEPS, START_EVALUATIONS, Hierarchical, Holistic, Trace


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
    x, fitness, used = Holistic().estimate(body, x_prev, f, CMAES(sigma0=0.3), 1500, np.random.default_rng(0))
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
    assert error[:3].max() < 5
    assert rotation_rms < 0.015


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
    Holistic().estimate(body, body.rest_pose(), Recorder(body.rest_pose()), spy, 100, np.random.default_rng(0))
    sizes = [len(p) for p in spy.space.partitions]
    assert sizes == [6, 9, 6, 6, 6, 6]
    assert np.array_equal(np.concatenate(spy.space.partitions), np.arange(39))


def test_custom_twelve_step_hierarchy(bodies):
    steps = [
        ["Root"],
        ["BottomSpine"],
        ["UpperSpine", "Neck"],
        ["LShoulder"],
        ["LElbow", "LWrist"],
        ["RShoulder"],
        ["RElbow", "RWrist"],
        ["LHip"],
        ["LKnee", "LAnkle"],
        ["RHip"],
        ["RKnee", "RAnkle"],
    ]
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
    steps = [
        ["Root"],
        ["BottomSpine", "UpperSpine", "Neck"],
        ["LShoulder", "LElbow"],
        ["LWrist", "RWrist"],
        ["RShoulder", "RElbow"],
        list(DEFAULT_STEPS[4]),
        list(DEFAULT_STEPS[5]),
    ]
    Hierarchical(steps=steps).step_groups(bodies[39])
    with pytest.raises(ConfigError, match="step 4 \\(LWrist, RWrist\\) has no degree of freedom in the 28-DOF"):
        Hierarchical(steps=steps).step_groups(bodies[28])
    # holistic search uses the steps only as partitions: the wrists' step is no partition
    ((partitions, budget),) = Holistic(steps=steps).plan(bodies[28], 100)
    assert len(partitions) == 6
    assert sum(len(p) for p in partitions) == 28
    assert budget == 100
    assert set(JOINTS) == {j for s in DEFAULT_STEPS for j in s}


def test_budget_below_one_population_is_a_config_error(bodies):
    body = bodies[39]
    with pytest.raises(
        ConfigError,
        match=r"tracking.evaluations=5 gives step 1 \(Root\) 1 "
        r"evaluations but optimizer 'cmaes' needs at least 9",
    ):
        Hierarchical().estimate(
            body, body.rest_pose(), Recorder(body.rest_pose()), CMAES(), 5, np.random.default_rng(0)
        )
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


def improvements(fitness: np.ndarray) -> np.ndarray:
    """(k, 2) (evaluation from 1, best so far) at every value below all before it, then at
    the last value: the convergence trace computed one evaluation at a time."""
    rows, best = [], np.inf
    for evaluation, value in enumerate(fitness, start=1):
        if value < best:
            best = value
            rows.append((evaluation, best))
    if rows[-1][0] != len(fitness):
        rows.append((len(fitness), best))
    return np.array(rows, dtype=float)


def test_a_trace_records_each_improvement_at_its_evaluation_within_the_batch():
    batches = [np.array([0.5]), np.array([0.7, 0.4, 0.45, 0.3]), np.array([0.3, 0.6]), np.array([0.2, 0.9])]
    values = iter(batches)
    trace = Trace(lambda X: next(values))
    for batch in batches:
        np.testing.assert_array_equal(trace(np.zeros((len(batch), 51))), batch)  # passed on unchanged
    np.testing.assert_array_equal(trace.rows(), [[1, 0.5], [3, 0.4], [5, 0.3], [8, 0.2], [9, 0.2]])
    np.testing.assert_array_equal(trace.rows(), improvements(np.concatenate(batches)))
    ends_better = Trace(lambda X: np.array([0.3, 0.1]))
    ends_better(np.zeros((2, 51)))
    np.testing.assert_array_equal(ends_better.rows(), [[1, 0.3], [2, 0.1]])  # no repeated last row
    assert Trace(lambda X: X).rows().shape == (0, 2)


@pytest.mark.parametrize(
    ("strategy", "recovered"),
    [(Holistic, False), (Hierarchical, False), (Holistic, True)],
    ids=["holistic", "hierarchical", "holistic-recovered"],
)
def test_every_frame_carries_the_trace_of_all_its_evaluations(bodies, strategy, recovered):
    """Each frame's trace is the best fitness so far over every candidate the frame evaluated
    (a recovery's too: one after every frame but the first), in order: rising evaluations from
    1, a falling fitness, ending at the frame's evaluations and fitness."""
    from types import SimpleNamespace

    from mmocap.stages import tracking

    body = bodies[39]
    recovery = Recovery(window=1, max_fitness=1e-9, evaluations=60) if recovered else None

    class Evaluator(Recorder):
        def setup(self, body, cameras, masks):
            pass

    target = body.rest_pose() + np.where(body.mask, 0.05, 0.0)
    evaluator = Evaluator(target)
    sequence = SimpleNamespace(n_frames=3, x0=body.rest_pose(), root="fake")
    foreground = SimpleNamespace(cameras=[], masks=lambda frame: [])
    results = tracking.track(
        sequence, body, foreground, evaluator, CMAES(), strategy(), evaluations=200, seed=0, recovery=recovery
    )
    fitness = np.concatenate([evaluator(batch) for batch in list(evaluator.batches)])
    if recovered:
        assert [event.frame for event in recovery.events] == [1, 2]
    spent = 0
    for result in results:
        trace = result.trace
        assert trace.shape[1] == 2
        assert trace[0, 0] == 1
        assert np.all(np.diff(trace[:, 0]) > 0)
        assert np.all(np.diff(trace[:, 1]) <= 0)
        assert trace[-1, 0] == result.evaluations == (260 if recovered and result.frame else 200)
        assert trace[-1, 1] == result.fitness
        np.testing.assert_array_equal(trace, improvements(fitness[spent : spent + result.evaluations]))
        spent += result.evaluations
    assert spent == len(fitness)
