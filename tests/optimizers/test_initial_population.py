"""DE and PSO start from the previous pose plus a population spread over init_spread radii."""

import numpy as np
import pytest

from mmocap.api import SearchSpace
from mmocap.optimizers.de import DifferentialEvolution
from mmocap.optimizers.pso import ParticleSwarm
from mmocap.testing.objectives import D


@pytest.mark.parametrize("cls", [DifferentialEvolution, ParticleSwarm])
def test_initial_population_holds_x0_and_spreads_init_spread_radii(cls):
    space = SearchSpace(x0=np.full(D, 0.5), lower=-np.ones(D), upper=np.ones(D), radius=np.full(D, 2.0), budget=100)
    for spread, lo, hi in [(1.0, -1.0, 1.0), (0.1, 0.3, 0.7)]:
        opt = cls(init_spread=spread)
        opt.setup(space, np.random.default_rng(0))
        X = opt.ask()
        np.testing.assert_array_equal(X[0], space.x0)
        assert X[1:].min() >= lo
        assert X[1:].max() <= hi
        assert X[1:].min() < lo + 0.1
        assert X[1:].max() > hi - 0.1
    opt = cls(include_x0=False)
    opt.setup(space, np.random.default_rng(0))
    assert not np.any(np.all(opt.ask() == space.x0, axis=1))
