"""Test functions and a run-to-the-end loop shared by the optimiser tests.

Functions map candidates X (n, D) to values (n,); minimum 0.
"""
import numpy as np

from mmocap.api import SearchSpace

D = 39
#: optimum 0.2 search radii from the start point in every coordinate, as in tracking
SHIFT = np.random.default_rng(123).choice([-1.0, 1.0], D) * 0.2


def sphere(X):
    return np.sum(X**2, axis=1)


def ellipsoid(X, condition=1e6):
    """Axis scales 1 ... ``condition`` (in f), log-spaced."""
    d = X.shape[1]
    return np.sum(condition ** (np.arange(d) / (d - 1)) * X**2, axis=1)


def ellipsoid_1e3(X):
    return ellipsoid(X, 1e3)


def rosenbrock(X):
    return np.sum(100 * (X[:, 1:] - X[:, :-1] ** 2) ** 2 + (1 - X[:, :-1]) ** 2, axis=1)


#: D-dimensional problems posed like one tracking frame: start point 0, a box of one search
#: radius (1) around it, optimum at SHIFT
TRACKING_LIKE = {
    "sphere": lambda X: sphere(X - SHIFT),
    "ellipsoid": lambda X: ellipsoid_1e3(X - SHIFT),
    "rosenbrock": lambda X: rosenbrock(X + 1 - SHIFT),
}


def box(dim, x0, bound, sigma0, budget):
    """Start ``x0``, bounds +-``bound``, radius ``sigma0`` in every coordinate."""
    ones = np.ones(dim)
    return SearchSpace(x0=x0 * ones, lower=-bound * ones, upper=bound * ones,
                       sigma0=sigma0 * ones, budget=budget)


def minimise(f, space, seed, opt, asked=None):
    """Run ``opt`` on ``f`` until it stops (appending each batch to ``asked``); its result."""
    opt.setup(space, np.random.default_rng(seed))
    while not opt.stop():
        X = opt.ask()
        if asked is not None:
            asked.append(X.copy())
        opt.tell(X, f(X))
    return opt.result


def random_search(f, space, seed):
    """Best of ``space.budget`` uniform samples in the box."""
    X = np.random.default_rng(seed).uniform(space.lower, space.upper, (space.budget, space.dim))
    return float(f(X).min())
