"""Interfaces shared by the stages: optimisers, evaluators and the search space.

Optimisers and evaluators are found through the entry-point groups
``mmocap.optimizers`` and ``mmocap.evaluators`` (see :mod:`mmocap.registry`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np


@dataclass(frozen=True)
class SearchSpace:
    """A box around a start point in which one frame (or one partition) is searched.

    Attributes:
        x0: (D,) start point, usually the previous frame's estimate.
        lower, upper: (D,) bounds, lower < upper element-wise.
        sigma0: (D,) search radius per coordinate in its own units (rad, mm): the unit
            of the optimisers' normalised coordinates and the scale of their first step.
        budget: maximum number of fitness evaluations for this search.
        partitions: optional groups of coordinate indices (each an int array into the D
            coordinates, together covering each coordinate once) in hierarchical order,
            e.g. root first, then torso, then each limb.  Partitioned-sampling optimisers
            (PSAPF) search them one after another; the others ignore them.  None means
            one partition holding every coordinate.
    """

    x0: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    sigma0: np.ndarray
    budget: int
    partitions: tuple[np.ndarray, ...] | None = None

    @property
    def dim(self) -> int:
        return int(self.x0.shape[0])


@dataclass
class Result:
    """Best point found so far."""

    xbest: np.ndarray
    fbest: float
    evaluations: int
    iterations: int
    stop_reasons: dict = field(default_factory=dict)


@runtime_checkable
class Optimizer(Protocol):
    """Batch ask/tell minimiser.

    ``setup`` starts a new search; then ``ask`` returns a whole population (n, D) that lies
    inside the bounds and never makes the evaluation count exceed ``space.budget``;
    ``tell`` takes the fitness (n,) of exactly what ``ask`` returned; ``stop`` returns
    ``{}`` to go on or a dict of reasons.
    """

    def setup(self, space: SearchSpace, rng: np.random.Generator) -> None: ...

    def ask(self) -> np.ndarray: ...

    def tell(self, X: np.ndarray, f: np.ndarray) -> None: ...

    def stop(self) -> dict: ...

    @property
    def result(self) -> Result: ...


@runtime_checkable
class Evaluator(Protocol):
    """Silhouette fitness of candidate poses (Yeguas Eq. 4-5).

    ``setup`` uploads one frame (body model, cameras, foreground masks); ``__call__`` maps
    poses (n, D_full) in the body's full parameter vector to fitness (n,) in [0, 1].
    """

    def setup(self, body, cameras, foreground) -> None: ...

    def __call__(self, X: np.ndarray) -> np.ndarray: ...

    def close(self) -> None: ...
