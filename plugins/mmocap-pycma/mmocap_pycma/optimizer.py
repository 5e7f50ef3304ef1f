"""pycma's ``CMAEvolutionStrategy`` behind mmocap's batch ask/tell optimiser protocol.

It subclasses :class:`mmocap.optimizers.base.PopulationOptimizer`, which keeps the budget
exact, clips candidates to the bounds, pairs ask with tell and tracks the best point; this
adapter only maps the search onto pycma:

- pycma runs in mmocap's normalised coordinates (``z = (x - x0) / radius``), starting at
  ``z = 0`` with step ``sigma0`` and pycma's own bound handling on the normalised box;
- its random numbers come from the ``numpy.random.Generator`` given to ``setup`` (pycma's
  ``randn`` option), never from numpy's global state;
- pycma cannot handle bounds in one dimension, so a 1-D search gets a second, ignored axis;
- a last generation cut short by the budget is evaluated but not told to pycma.
"""

from __future__ import annotations

import math

import cma
import numpy as np

from mmocap.optimizers.base import PopulationOptimizer
from mmocap.validate import check_number


class PycmaOptimizer(PopulationOptimizer):
    """pycma's CMA-ES minimiser following the :class:`mmocap.api.Optimizer` protocol.

    Args:
        popsize: lambda, or ``None`` for pycma's default ``4 + floor(3 ln D)``.
        sigma0: initial step, unitless: a fraction of the search radius ``space.radius`` (> 0).
    """

    name = "pycma"

    def __init__(self, popsize: int | None = None, sigma0: float = 0.03):
        super().__init__()
        self.popsize = None if popsize is None else check_number("optimizer.popsize", popsize, 2, integer=True)
        self.sigma0 = check_number("optimizer.sigma0", sigma0, 0.0, low_open=True)

    def population_size(self, dim: int) -> int:
        return self.popsize or 4 + math.floor(3 * math.log(dim))

    def _start(self) -> None:
        rng = self.rng
        pad = [1.0] if self.dim == 1 else []  # the ignored second axis of a 1-D search
        options = {
            "popsize": self.population_size(self.dim),
            "bounds": [list(self.to_unit(self.lower)) + [-p for p in pad], list(self.to_unit(self.upper)) + pad],
            "randn": lambda *shape: rng.standard_normal(shape),
            "seed": float("nan"),
            "maxfevals": self.budget,
            "verbose": -9,
        }
        self._es = cma.CMAEvolutionStrategy(np.zeros(self.dim + len(pad)), self.sigma0, options)

    def _propose(self, n_max: int) -> np.ndarray:
        self._z = np.array(self._es.ask())
        return self.from_unit(self._z[:n_max, : self.dim])

    def _learn(self, X: np.ndarray, f: np.ndarray) -> None:
        if len(X) == len(self._z):
            self._es.tell(list(self._z), list(f))

    def _reasons(self) -> dict:
        return {k: v for k, v in self._es.stop().items() if k != "maxfevals"}
