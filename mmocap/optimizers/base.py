"""Shared machinery of the built-in optimisers: search-space checks, exact budget, ask/tell
pairing, best-so-far bookkeeping and stop reasons.

A subclass implements four hooks and inherits the :class:`mmocap.api.Optimizer` protocol:

- ``population_size(dim)``: candidates per generation (or per layer); a search whose budget
  is smaller than :meth:`PopulationOptimizer.min_budget` is a ConfigError;
- ``_start()``: initialise its state once ``setup`` has checked and stored the space;
- ``_propose(n_max)``: the next candidates (n, D), 1 <= n <= n_max (the evaluations left),
  in original units; the base class clips them to the bounds before they are evaluated;
- ``_learn(X, f)``: update from the clipped candidates X (n, D) and their fitness f (n,);
- optionally ``_reasons()``: extra stop reasons (dict), asked only after the first ``tell``.

Normalised coordinates ``z = (x - x0) / scale`` (``scale = space.radius``, the search radius
of each coordinate) make one unit the search radius in every coordinate (rad or mm alike);
:meth:`PopulationOptimizer.to_unit` and :meth:`PopulationOptimizer.from_unit` convert.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import cast

import numpy as np

from mmocap.api import Result, SearchSpace
from mmocap.errors import ConfigError


class PopulationOptimizer(ABC):
    """Base class of batch ask/tell minimisers; see the module docstring for the hooks."""

    #: name used in error messages; subclasses set their registry name
    name = "optimizer"

    def __init__(self) -> None:
        self._space: SearchSpace | None = None

    # -- hooks -------------------------------------------------------------------------------
    @abstractmethod
    def population_size(self, dim: int) -> int:
        """Candidates per generation for ``dim`` coordinates."""

    @abstractmethod
    def _start(self) -> None:
        """Initialise the search state (called at the end of ``setup``)."""

    @abstractmethod
    def _propose(self, n_max: int) -> np.ndarray:
        """The next candidates (n, D), 1 <= n <= n_max, original units."""

    @abstractmethod
    def _learn(self, X: np.ndarray, f: np.ndarray) -> None:
        """Update from the evaluated candidates X (n, D) and their fitness f (n,)."""

    def _reasons(self) -> dict[str, float]:
        return {}

    # -- protocol ----------------------------------------------------------------------------
    def min_budget(self, dim: int, partitions: int = 1) -> int:
        """Smallest evaluation budget a search of ``dim`` coordinates in ``partitions``
        partitions can use: one population by default."""
        return self.population_size(dim)

    def setup(self, space: SearchSpace, rng: np.random.Generator) -> None:
        """Start a new search in ``space``; all randomness comes from ``rng``."""
        x0 = np.asarray(space.x0, dtype=float)
        if x0.ndim != 1 or x0.shape[0] == 0:
            raise ConfigError(f"search space x0 must have shape (D,), got {x0.shape}")
        dim = x0.shape[0]
        lower, upper, scale = (
            np.broadcast_to(np.asarray(a, dtype=float), (dim,)).copy() for a in (space.lower, space.upper, space.radius)
        )
        if not np.all(scale > 0):
            raise ConfigError(f"search space radius must be > 0, got {scale}")
        if not np.all(lower < upper):
            raise ConfigError("search space bounds must satisfy lower < upper")
        n_parts = 1 if space.partitions is None else len(space.partitions)
        needed = self.min_budget(dim, n_parts)
        if space.budget < needed:
            raise ConfigError(
                f"optimizer '{self.name}' needs a budget of at least {needed} "
                f"evaluations for {dim} coordinates in {n_parts} partition(s), "
                f"got {space.budget}"
            )
        self._space = space
        self.x0, self.lower, self.upper, self.scale = x0, lower, upper, scale
        self.dim = dim
        self.budget = int(space.budget)
        self.rng = rng
        self.evaluations = 0
        self.iterations = 0
        self._xbest = np.clip(x0, lower, upper)
        self._fbest = math.inf
        self._pending: np.ndarray | None = None
        self._start()

    def ask(self) -> np.ndarray:
        """Return the next candidates (n, D) in original units, inside the bounds."""
        self._require_setup()
        if self._pending is not None:
            raise RuntimeError("ask() called again before tell()")
        remaining = self.budget - self.evaluations
        if remaining <= 0:
            raise RuntimeError(f"evaluation budget of {self.budget} is exhausted")
        X: np.ndarray = np.asarray(self._propose(remaining), dtype=float)
        if X.ndim != 2 or X.shape[1] != self.dim or not 1 <= X.shape[0] <= remaining:
            raise RuntimeError(
                f"{type(self).__name__} proposed an array of shape {X.shape}; "
                f"expected (n, {self.dim}) with 1 <= n <= {remaining}"
            )
        X = np.clip(X, self.lower, self.upper)
        self._pending = X
        return X.copy()

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        """Take the fitness f (n,) of exactly the candidates X (n, D) that :meth:`ask` returned."""
        self._require_setup()
        if self._pending is None:
            raise RuntimeError("tell() called without a preceding ask()")
        asked = self._pending
        X = np.asarray(X)
        f = np.asarray(f, dtype=float)
        # equal bytes of equal dtype are the same values: the element-wise test,
        # several times dearer on a generation's array, is only needed when they differ
        same = X.dtype == asked.dtype and X.tobytes() == asked.tobytes()
        if X.shape != asked.shape or not (same or (X == asked).all()):
            raise ValueError(f"tell() needs exactly the {asked.shape} array that ask() returned, got shape {X.shape}")
        if f.shape != (X.shape[0],):
            raise ValueError(f"tell() needs fitness of shape ({X.shape[0]},), got {f.shape}")
        best = int(f.argmin())  # the first NaN if there is one
        if math.isnan(f[best]):
            raise ValueError("tell() got NaN fitness values")
        self._pending = None
        self.evaluations += X.shape[0]
        self.iterations += 1
        if f[best] < self._fbest:
            self._fbest = float(f[best])
            self._xbest = asked[best].copy()
        self._learn(asked, f)

    def stop(self) -> dict[str, float]:
        """``{}`` to go on, else the reasons: ``budget`` (evaluations used) and the
        subclass's own."""
        self._require_setup()
        reasons: dict[str, float] = {}
        if self.evaluations >= self.budget:
            reasons["budget"] = self.evaluations
        if self.iterations > 0:
            reasons.update(self._reasons())
        return reasons

    @property
    def result(self) -> Result:
        """Best point over all evaluations; before the first tell ``fbest`` is inf (and
        ``xbest`` is (0,) before setup, so that ``isinstance(opt, Optimizer)`` works)."""
        if self._space is None:
            return Result(np.empty(0), math.inf, 0, 0, {})
        return Result(self._xbest.copy(), self._fbest, self.evaluations, self.iterations, self.stop())

    # -- helpers for subclasses --------------------------------------------------------------
    def to_unit(self, X: np.ndarray) -> np.ndarray:
        """Original units -> normalised coordinates (one unit = the search radius)."""
        return cast(np.ndarray, (X - self.x0) / self.scale)

    def from_unit(self, Z: np.ndarray) -> np.ndarray:
        """Normalised coordinates -> original units."""
        return cast(np.ndarray, self.x0 + self.scale * Z)

    def _require_setup(self) -> None:
        if self._space is None:
            raise RuntimeError("call setup() before using the optimiser")
