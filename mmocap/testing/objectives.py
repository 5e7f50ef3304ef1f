"""Test functions, search boxes and a run-to-the-end loop, shared by the optimiser tests and
the conformance suite (:mod:`mmocap.testing.optimizers`).

Functions map candidates X (n, D) to values (n,), with minimum 0. Coordinates are unitless,
like a tracking frame's search space measured in search radii.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from mmocap.api import Optimizer, Result, SearchSpace

#: the dimension of the 39-DOF body model
D = 39
#: an optimum 0.2 search radii from the start in every coordinate (D,), as in tracking
SHIFT = np.random.default_rng(123).choice([-1.0, 1.0], D) * 0.2


def sphere(X: np.ndarray, centre: np.ndarray | float = 0.0) -> np.ndarray:
    """Squared distance (n,) of the rows of X (n, D) to ``centre`` (D,) or a scalar."""
    return np.sum((X - centre) ** 2, axis=1)


def ellipsoid(X: np.ndarray, condition: float = 1e6) -> np.ndarray:
    """Axis scales 1 ... ``condition`` (in f), log-spaced over the D coordinates."""
    d = X.shape[1]
    return np.sum(condition ** (np.arange(d) / (d - 1)) * X**2, axis=1)


def ellipsoid_1e3(X: np.ndarray) -> np.ndarray:
    """The ellipsoid with condition 1e3."""
    return ellipsoid(X, 1e3)


def rosenbrock(X: np.ndarray) -> np.ndarray:
    """Rosenbrock's valley, optimum at (1, ..., 1)."""
    return np.sum(100 * (X[:, 1:] - X[:, :-1] ** 2) ** 2 + (1 - X[:, :-1]) ** 2, axis=1)


#: D-dimensional problems posed like one tracking frame: start 0, a box of one search radius
#: around it, optimum at SHIFT
TRACKING_LIKE = {
    "sphere": lambda X: sphere(X, SHIFT),
    "ellipsoid": lambda X: ellipsoid_1e3(X - SHIFT),
    "rosenbrock": lambda X: rosenbrock(X + 1 - SHIFT),
}


def box(
    dim: int = D, x0: float = 0.0, bound: float = 1.0, radius: float = 1.0, budget: int = 1500, partitions=None
) -> SearchSpace:
    """Start ``x0``, bounds +-``bound`` and radius ``radius`` in every one of ``dim`` coordinates."""
    ones = np.ones(dim)
    return SearchSpace(
        x0=x0 * ones,
        lower=-bound * ones,
        upper=bound * ones,
        radius=radius * ones,
        budget=budget,
        partitions=partitions,
    )


class Run(NamedTuple):
    """One optimiser run to its end."""

    asked: list[np.ndarray]  # the candidate batches, (n_i, D) each
    values: list[np.ndarray]  # their function values, (n_i,) each
    result: Result


def minimise(optimizer: Optimizer, f, space: SearchSpace, seed: int) -> Run:
    """Run ``optimizer`` on ``f`` in ``space`` from ``seed`` until it stops."""
    optimizer.setup(space, np.random.default_rng(seed))
    asked, values = [], []
    while not optimizer.stop():
        X = optimizer.ask()
        asked.append(X.copy())
        values.append(f(X))
        optimizer.tell(X, values[-1])
    return Run(asked, values, optimizer.result)


def random_search(f, space: SearchSpace, seed: int) -> float:
    """The best of ``space.budget`` uniform samples in the box."""
    X = np.random.default_rng(seed).uniform(space.lower, space.upper, (space.budget, space.dim))
    return float(f(X).min())
