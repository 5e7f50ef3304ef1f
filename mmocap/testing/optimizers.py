"""Conformance suite for optimiser plugins (pytest).

Every optimiser registered under the ``mmocap.optimizers`` entry points must pass it. A
plugin reuses it in one line of its own tests::

    from mmocap.testing.optimizers import OptimizerConformance

    class TestMyOptimizer(OptimizerConformance):
        name = "myopt"          # the entry-point name; ``params`` may set constructor args

The suite checks the contract of :class:`mmocap.api.Optimizer` that the tracker relies on:
registration and a composable ``conf/optimizer/<name>.yaml``, the exact evaluation budget,
candidates inside the bounds, ask/tell pairing, reproducibility from the seed, partitions,
a clear error for a budget below the optimiser's ``min_budget``, real progress on a
sphere, and both tracking strategies on the 39-DOF body model.
"""

from __future__ import annotations

import numpy as np
import pytest

from mmocap import config, registry
from mmocap.api import Optimizer, SearchSpace
from mmocap.errors import ConfigError
from mmocap.testing.objectives import minimise, sphere


def min_budget(optimizer, dim: int, partitions: int = 1) -> int:
    """The optimiser's smallest budget (1 if it does not say)."""
    return int(getattr(optimizer, "min_budget", lambda d, p=1: 1)(dim, partitions))


def asymmetric_box(dim: int, budget: int, partitions=None) -> SearchSpace:
    """An asymmetric box around a start point near its upper bounds, radius 0.5."""
    x0 = np.linspace(-0.3, 0.3, dim)
    return SearchSpace(
        x0=x0,
        lower=x0 - 0.5,
        upper=np.minimum(x0 + 0.5, 0.35),
        radius=np.full(dim, 0.5),
        budget=budget,
        partitions=partitions,
    )


class OptimizerConformance:
    """Subclass with ``name`` (entry-point name) and optionally ``params`` (constructor
    arguments) to run the suite on one optimiser."""

    name: str = ""
    params: dict = {}

    @pytest.fixture
    def optimizer_name(self) -> str:
        return self.name

    @pytest.fixture
    def make(self, optimizer_name):
        """Factory of fresh optimiser instances."""
        return lambda: registry.make_optimizer(optimizer_name, **self.params)

    def test_is_registered_and_follows_the_protocol(self, optimizer_name, make):
        assert optimizer_name in registry.available("optimizer")
        opt = make()
        assert isinstance(opt, Optimizer)
        assert opt.result.evaluations == 0
        with pytest.raises(RuntimeError):
            opt.ask()

    def test_config_file_composes_and_instantiates(self, optimizer_name):
        from hydra.utils import instantiate

        cfg = config.compose([f"optimizer={optimizer_name}"])
        assert cfg.optimizer.name == optimizer_name
        assert isinstance(instantiate(cfg.optimizer), Optimizer)

    @pytest.mark.parametrize("dim", [1, 7, 39])
    def test_budget_is_exact_and_points_stay_in_bounds(self, make, dim):
        opt = make()
        smallest = min_budget(opt, dim)
        for budget in sorted({smallest, smallest + 1, 3 * smallest + 7, 157 + smallest}):
            space = asymmetric_box(dim, budget)
            done = minimise(opt, lambda X, upper=space.upper: sphere(X, upper), space, seed=budget)
            asked, result = done.asked, done.result
            X = np.concatenate(asked)
            assert len(X) == result.evaluations <= budget
            assert X.shape[1] == dim
            assert np.all((X >= space.lower) & (X <= space.upper))
            # an optimiser may stop early (converged), but then it says why
            assert ("budget" in result.stop_reasons) == (len(X) == budget)
            assert result.stop_reasons
            assert result.fbest == pytest.approx(sphere(X, space.upper).min())
            if len(X) == budget:
                with pytest.raises(RuntimeError):
                    opt.ask()

    def test_budget_below_min_budget_is_a_config_error(self, make):
        opt = make()
        smallest = min_budget(opt, 10)
        if smallest <= 1:
            pytest.skip("any budget >= 1 is accepted")
        with pytest.raises(ConfigError):
            opt.setup(asymmetric_box(10, smallest - 1), np.random.default_rng(0))

    def test_ask_tell_pairing_is_enforced(self, make):
        opt = make()
        space = asymmetric_box(5, 10 * min_budget(opt, 5))
        opt.setup(space, np.random.default_rng(0))
        X = opt.ask()
        with pytest.raises(RuntimeError):
            opt.ask()
        # any wording: the message is the optimiser's own (PT011)
        with pytest.raises(ValueError):  # noqa: PT011
            opt.tell(X + 1e-3, sphere(X, space.x0))
        with pytest.raises(ValueError):  # noqa: PT011
            opt.tell(X, sphere(X, space.x0)[:-1] if len(X) > 1 else np.zeros(2))
        with pytest.raises(ValueError):  # noqa: PT011
            opt.tell(X, np.full(len(X), np.nan))
        opt.tell(X, sphere(X, space.x0))
        with pytest.raises(RuntimeError):
            opt.tell(X, sphere(X, space.x0))

    def test_same_seed_same_search_other_seed_other_search(self, make):
        space = asymmetric_box(12, 20 * min_budget(make(), 12))

        def batches(seed):
            return np.concatenate(minimise(make(), sphere, space, seed).asked)

        assert np.array_equal(batches(1), batches(1))
        assert not np.array_equal(batches(1), batches(2))

    def test_makes_progress_on_a_sphere(self, make):
        # Optimum 0.2 radius away from the start in every coordinate. The best of 1000
        # uniform samples in the box is 1.3 times worse than the start; evolutionary
        # algorithms reach 0.3 to 1e-9 of it, the particle filters 0.2 to 0.45.
        dim = 10
        space = asymmetric_box(dim, 1000)
        centre = space.x0 - 0.1
        result = minimise(make(), lambda X: sphere(X, centre), space, seed=0).result
        assert result.fbest < 0.5 * sphere(space.x0[None], centre)[0]

    def test_accepts_partitions(self, make):
        dim = 9
        parts = (np.arange(0, 3), np.arange(3, 4), np.arange(4, 9))
        opt = make()
        space = asymmetric_box(dim, 500, partitions=parts)
        done = minimise(opt, lambda X: sphere(X, space.x0 - 0.1), space, seed=0)
        asked, result = done.asked, done.result
        assert sum(len(X) for X in asked) == result.evaluations <= space.budget
        assert result.fbest < sphere(space.x0[None], space.x0 - 0.1)[0]

    @pytest.mark.parametrize("strategy", ["holistic", "hierarchical"])
    def test_tracks_one_frame_of_the_body_model(self, make, strategy, body39):
        """On a quadratic around a pose 0.02 rad from the start, over four seeds: every
        frame uses the budget exactly, is never worse than its start, and most improve."""
        from mmocap.stages.tracking import Hierarchical, Holistic

        x_prev = body39.rest_pose()
        target = x_prev + np.where(body39.mask, 0.02, 0.0)
        weights = np.where(np.arange(len(x_prev)) < 3, 1e-4, 1.0)  # mm vs rad

        def fitness(X):
            return np.sum(weights * (X - target) ** 2, axis=1)

        start = fitness(x_prev[None])[0]
        found = []
        for seed in range(4):
            searched = {"holistic": Holistic, "hierarchical": Hierarchical}[strategy]()
            x, f, used = searched.estimate(body39, x_prev, fitness, make(), 1500, np.random.default_rng(seed))
            assert used == 1500
            assert x.shape == x_prev.shape
            assert np.array_equal(x[~body39.mask], x_prev[~body39.mask])
            assert f == pytest.approx(fitness(x[None])[0])
            assert f <= start, f"seed {seed}: the frame ended worse ({f}) than its start ({start})"
            found.append(f)
        assert np.median(found) < start, f"no improvement on the start ({start}): {found}"

    @pytest.fixture(scope="class")
    @classmethod
    def body39(cls):
        from mmocap.body.model import BodyModel

        return BodyModel("S1", dof=39)
