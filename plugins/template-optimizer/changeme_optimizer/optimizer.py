# TEMPLATE: rename the class ChangemeRandomLocalSearch and its name changeme-rls (also in
# pyproject.toml, conf/optimizer/changeme-rls.yaml and tests/), then replace the algorithm.
"""Random local search: an example optimiser to replace with your own.

A subclass of :class:`mmocap.optimizers.base.PopulationOptimizer` fills in four hooks; the
base class keeps the budget exact, clips candidates to the search box, checks that ``tell``
gets what ``ask`` returned and tracks the best point. After ``setup`` it holds ``x0``,
``lower``, ``upper``, ``scale`` (the search radius per coordinate), ``dim``, ``budget``,
``rng`` (take all randomness from it), ``evaluations``, ``iterations`` and ``result``;
``to_unit`` / ``from_unit`` convert to and from normalised coordinates, in which ``x0`` is
0 and one unit is the search radius in every coordinate (rad or mm alike).
"""

from __future__ import annotations

import numpy as np

from mmocap.optimizers.base import PopulationOptimizer
from mmocap.validate import check_number


class ChangemeRandomLocalSearch(PopulationOptimizer):
    """Samples around the best point so far, shrinking the spread each generation; the
    first generation includes the start point.

    Args:
        popsize: candidates per generation (>= 1).
        init_spread: standard deviation of the first generation, fraction of the search
            radius (> 0).
        shrink: factor on the spread after each generation, in (0, 1].
    """

    name = "changeme-rls"  # the entry-point name, used in error messages

    # Every default here is the one of conf/optimizer/changeme-rls.yaml (the tests check it).
    def __init__(self, popsize: int = 20, init_spread: float = 0.05, shrink: float = 0.9):
        super().__init__()
        # Check each argument here, so that a bad value is a one-line error naming its key.
        self.popsize = check_number("optimizer.popsize", popsize, 1, integer=True)
        self.init_spread = check_number("optimizer.init_spread", init_spread, 0.0, low_open=True)
        self.shrink = check_number("optimizer.shrink", shrink, 0.0, 1.0, low_open=True)

    def population_size(self, dim: int) -> int:
        """Candidates per generation; a budget below it is a ConfigError before any work."""
        return self.popsize

    def _start(self) -> None:
        """A new search (one frame, or one step of a hierarchical search) starts."""
        self.spread = self.init_spread

    def _propose(self, n_max: int) -> np.ndarray:
        """(n, D) candidates, 1 <= n <= n_max (the evaluations left), original units."""
        n = min(self.popsize, n_max)
        Z = self.to_unit(self.result.xbest) + self.spread * self.rng.standard_normal((n, self.dim))
        if self.iterations == 0:
            Z[0] = 0.0  # the start point itself: the search never ends worse than it started
        return self.from_unit(Z)

    def _learn(self, X: np.ndarray, f: np.ndarray) -> None:
        """Fitness f (n,) of the clipped candidates X (n, D) of the last _propose."""
        self.spread *= self.shrink
