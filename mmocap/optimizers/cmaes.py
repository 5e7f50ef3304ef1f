"""CMA-ES (Yeguas et al. 2014, Sec. 4.2.1, Fig. 4, Table 2) as a batch ask/tell minimiser.

Units. The search runs in normalised coordinates ``z = (x - space.x0) / space.radius``
(``space.radius`` holds the search radius of each coordinate): the mean starts at ``z = 0``
(the start point), the covariance at the identity and the internal step size ``sigma`` at
the constructor's ``sigma0``, so coordinate ``j`` is first sampled with standard deviation
``sigma0 * space.radius[j]`` in its own units (rad for rotations, mm for translations).
This is the per-coordinate scaling of pycma's ``scaling_of_variables``.
Candidates returned by :meth:`CMAES.ask` and the result are in the original units.

Bounds (``bounds``). ``"transform"`` (the default) samples an unbounded genotype and maps
each coordinate into its box by a periodic linear-quadratic transformation (the idea of
pycma's BoundTransform; Hansen 2009): the identity inside the box, a quadratic over a margin
``a = min(width / 2, (1 + |bound|) / 20)`` (normalised units) on either side of each bound
that reaches the bound with zero slope, and reflections beyond. A bound is then an
optimum that the search can sit on with a full-rank covariance. The update uses the
genotypes; the mean starts at the inverse image of the start point and is moved back by
whole periods (which leaves the distribution of candidates unchanged) when it drifts out.
``"clip"`` clips each candidate to ``[space.lower, space.upper]`` and updates with the
clipped points re-normalised (coordinates that were not clipped keep their exact sampled
value). On a 10-D ellipsoid whose optimum lies on the bound in half the coordinates, clipping
needs about 4x the evaluations of pycma and collapses the covariance along the bound
(``tests/optimizers/test_cmaes.py``).

Budget. A search needs at least one generation (``lambda`` evaluations). Generations have
``lambda`` candidates, except that the last one is truncated so that the number of evaluations
reaches ``space.budget`` exactly and never exceeds it. A truncated generation with at least
``mu`` candidates is used for a full update over its best ``mu``; one with fewer only updates
the best point.

Eigendecomposition. Sampling needs ``C = B diag(D^2) B^T``. ``C`` is updated every
generation, but it moves by at most ``c_cov`` per generation, so its eigendecomposition is
redone only when ``LAZY_EIGEN / (c_cov D)`` generations have passed since the last one (about
every 4 generations at 39 DOF and lambda 14; every generation in small dimensions), the lazy
update of pycma; in between, candidates are sampled from the last decomposed ``C``. At 39 DOF
the decomposition, done every generation, would be a large share of CMA-ES's own time.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import cast

import numpy as np

from mmocap.errors import ConfigError
from mmocap.optimizers.base import PopulationOptimizer
from mmocap.validate import check_number

_MAX_CONDITION = 1e14
#: generations between eigendecompositions of C, times c_cov * D (see the module docstring)
LAZY_EIGEN = 0.5
#: the values of ``optimizer.bounds``
BOUND_HANDLING = ("transform", "clip")


class BoxTransform:
    """Periodic linear-quadratic map of unbounded genotypes onto the box ``[lower, upper]``.

    Args:
        lower: (D,) finite lower bounds, ``lower < upper``, in the units of the genotypes
            (the optimiser's normalised coordinates).
        upper: (D,) finite upper bounds, in the same units.

    Per coordinate, with margins ``a_l, a_u = min(width / 2, (1 + |bound|) / 20)``: the
    identity on ``[lower + a_l, upper - a_u]``; ``lower + (y - lower + a_l)^2 / (4 a_l)`` on
    ``[lower - a_l, lower + a_l]`` and its mirror image at the upper bound, which meet the
    identity with slope 1 and the bounds with slope 0; beyond ``[lower - a_l, upper + a_u]``
    the map is reflected, which makes it periodic with period
    ``2 (upper - lower + a_l + a_u)``.
    """

    def __init__(self, lower: np.ndarray, upper: np.ndarray):
        lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
        if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
            raise ConfigError(
                "optimizer.bounds=transform needs finite search bounds; use "
                "optimizer.bounds=clip for a search space with infinite bounds"
            )
        half_width = (upper - lower) / 2
        self.lower, self.upper = lower, upper
        self.margin_lower = np.minimum(half_width, (1 + np.abs(lower)) / 20)
        self.margin_upper = np.minimum(half_width, (1 + np.abs(upper)) / 20)
        self._start = lower - self.margin_lower  # the base period is [start, start + period)
        self._end = upper + self.margin_upper
        self._period = 2 * (self._end - self._start)
        self._period_end = self._start + self._period
        # the map's constants, computed once: each call is a dozen small array operations
        self._twice_end = 2 * self._end
        self._four_margin_lower = 4 * self.margin_lower
        self._four_margin_upper = 4 * self.margin_upper
        # where the map is the identity (most coordinates of a tracked frame; joints at a limit are not)
        self._identity = (lower + self.margin_lower, upper - self.margin_upper)
        # the same constants per coordinate as Python floats, for the few genotypes beyond a margin
        self._coordinates = list(
            zip(
                *(
                    a.tolist()
                    for a in (
                        self._start,
                        self._period_end,
                        self._period,
                        self._end,
                        self._twice_end,
                        *self._identity,
                        lower,
                        upper,
                        self._four_margin_lower,
                        self._four_margin_upper,
                    )
                )
            )
        )

    def base_period(self, Y: np.ndarray) -> np.ndarray:
        """Genotypes (..., D) moved by whole periods into the base period (same image);
        those already in it are returned unchanged (no rounding)."""
        inside = (Y >= self._start) & (Y < self._period_end)
        if np.count_nonzero(inside) == inside.size:  # cheaper than inside.all() on small arrays
            return Y
        return np.where(inside, Y, self._start + np.mod(Y - self._start, self._period))

    def __call__(self, Y: np.ndarray) -> np.ndarray:
        """Images (..., D) in the box of the genotypes Y (..., D)."""
        inner_low, inner_high = self._identity
        below, above = Y < inner_low, Y > inner_high
        n_below, n_above = np.count_nonzero(below), np.count_nonzero(above)
        if not (n_below or n_above):  # the same values, without the work
            return Y
        # a search at a bound seldom reaches the other one: its side is skipped; the signs of the
        # differences are exact, so they find the few genotypes beyond a margin
        X = Y
        if n_below:
            from_start = Y - self._start
            X = np.where(below, self.lower + from_start**2 / self._four_margin_lower, X)
            self._fold_beyond(Y, X, np.flatnonzero(from_start < 0))
        if n_above:
            from_end = Y - self._end
            X = np.where(above, self.upper - from_end**2 / self._four_margin_upper, X)
            self._fold_beyond(Y, X, np.flatnonzero(from_end > 0))
        return X

    def _fold_beyond(self, Y: np.ndarray, X: np.ndarray, beyond: np.ndarray) -> None:
        """Write into the images X (..., D), a new array, those of the genotypes Y (..., D)
        at the flat indices ``beyond`` (k,), outside ``[start, end]``: moved by whole periods
        into the base period, reflected, then mapped, one by one (they are few) by the
        operations that map the arrays, in the same order, so with the same rounding."""
        if not beyond.size:
            return
        dim = Y.shape[-1]
        images = X.reshape(-1)
        for i, y in zip(beyond.tolist(), Y.reshape(-1)[beyond].tolist()):
            start, period_end, period, end, twice_end, inner_low, inner_high, lower, upper, quad_low, quad_up = (
                self._coordinates[i % dim]
            )
            if not start <= y < period_end:  # Python's float % rounds as np.mod does
                y = start + (y - start) % period
            if y > end:
                y = twice_end - y
            if y < inner_low:
                y = lower + (y - start) * (y - start) / quad_low
            elif y > inner_high:
                y = upper - (y - end) * (y - end) / quad_up
            images[i] = y

    def inverse(self, X: np.ndarray) -> np.ndarray:
        """A genotype (..., D) in ``[lower - a_l, upper + a_u]`` of each point X (..., D) of
        the box (points outside are clipped first)."""
        X = np.clip(X, self.lower, self.upper)
        low = self._start + np.sqrt(np.maximum(4 * self.margin_lower * (X - self.lower), 0.0))
        high = self._end - np.sqrt(np.maximum(4 * self.margin_upper * (self.upper - X), 0.0))
        inner_low, inner_high = self._identity
        Y = np.where(X < inner_low, low, X)
        return np.where(X > inner_high, high, Y)


@dataclass(frozen=True)
class StrategyParameters:
    """Default strategy parameters of Table 2 for dimension ``dim``.

    Attributes:
        dim: D, the number of searched coordinates.
        lam: lambda, candidates per generation.
        mu: number of parents recombined into the mean.
        weights: (mu,) positive log-decreasing recombination weights summing to 1.
        mu_eff: variance effective selection mass, 1 / sum(w_i^2).
        c_sigma, d_sigma: learning rate and damping of the step-size control.
        c_c: learning rate of the covariance evolution path.
        mu_cov: weighting between rank-one and rank-mu update (= mu_eff).
        c_cov: learning rate of the covariance matrix.
        chi_n: E||N(0, I)||, approximated as sqrt(D) (1 - 1/(4D) + 1/(21 D^2)).
    """

    dim: int
    lam: int
    mu: int
    weights: np.ndarray
    mu_eff: float
    c_sigma: float
    d_sigma: float
    c_c: float
    mu_cov: float
    c_cov: float
    chi_n: float


def strategy_parameters(dim: int, popsize: int | None = None) -> StrategyParameters:
    """Table 2 parameters for dimension ``dim``; ``popsize`` replaces lambda when given."""
    if dim < 1:
        raise ConfigError(f"search space dimension must be >= 1, got {dim}")
    lam = popsize if popsize is not None else 4 + math.floor(3 * math.log(dim))
    mu = lam // 2
    raw = math.log(mu + 1) - np.log(np.arange(1, mu + 1))
    weights = raw / raw.sum()
    mu_eff = float(1.0 / np.sum(weights**2))
    c_sigma = (mu_eff + 2) / (dim + mu_eff + 3)
    d_sigma = 1 + 2 * max(0.0, math.sqrt((mu_eff - 1) / (dim + 1)) - 1) + c_sigma
    c_c = 4 / (dim + 4)
    mu_cov = mu_eff
    c_cov = (1 / mu_cov) * 2 / (dim + math.sqrt(2)) ** 2 + (1 - 1 / mu_cov) * min(
        1.0, (2 * mu_eff - 1) / ((dim + 2) ** 2 + mu_eff)
    )
    chi_n = math.sqrt(dim) * (1 - 1 / (4 * dim) + 1 / (21 * dim**2))
    return StrategyParameters(dim, lam, mu, weights, mu_eff, c_sigma, d_sigma, c_c, mu_cov, c_cov, chi_n)


class CMAES(PopulationOptimizer):
    """CMA-ES minimiser following the :class:`mmocap.api.Optimizer` protocol.

    Args:
        popsize: lambda; ``None`` uses Table 2, ``4 + floor(3 ln D)``. At least 2.
        sigma0: initial step size (pycma's name), unitless: a fraction of the search radius
            ``space.radius``, not a length or an angle. 1.0 is Yeguas Table 3 (step =
            radius = 0.5 rad); smaller values suit the small motion between video frames
            better. Must be > 0.
        tolx: stop when every coordinate's standard deviation ``sigma * sqrt(C_jj) *
            space.radius[j]`` (original units) is below this. Must be >= 0.
        tolfun: stop when the range of f in the last generation and of the best f over the
            last ``10 + ceil(30 D / lambda)`` generations is below this. Must be >= 0.
        bounds: ``"transform"`` or ``"clip"``, the boundary handling of the module docstring.
    """

    name = "cmaes"

    def __init__(
        self,
        popsize: int | None = None,
        sigma0: float = 0.03,
        tolx: float = 1e-12,
        tolfun: float = 1e-12,
        bounds: str = "transform",
    ):
        super().__init__()
        self.popsize = None if popsize is None else check_number("optimizer.popsize", popsize, 2, integer=True)
        self.sigma0 = check_number("optimizer.sigma0", sigma0, 0.0, low_open=True)
        self.tolx = check_number("optimizer.tolx", tolx, 0.0)
        self.tolfun = check_number("optimizer.tolfun", tolfun, 0.0)
        if bounds not in BOUND_HANDLING:
            raise ConfigError(f"optimizer.bounds must be one of {', '.join(BOUND_HANDLING)}, got {bounds!r}")
        self.bounds = bounds
        self.params: StrategyParameters | None = None

    def population_size(self, dim: int) -> int:
        return strategy_parameters(dim, self.popsize).lam

    def _start(self) -> None:
        dim = self.dim
        self.params = p = strategy_parameters(dim, self.popsize)
        self._mean = np.zeros(dim)
        if self.bounds == "transform":
            self._box = BoxTransform(self.to_unit(self.lower), self.to_unit(self.upper))
            self._mean = self._box.inverse(self._mean)
        self._sigma = self.sigma0
        self._C = np.eye(dim)
        self._B = np.eye(dim)
        self._D = np.ones(dim)
        self._condition = 1.0  # cond(C) from D, (max D / min D)^2, kept with D
        self._p_sigma = np.zeros(dim)
        self._p_c = np.zeros(dim)
        self._updates = 0
        self._eigen_updates = 0  # self._updates when B and D were last computed from C
        self._eigen_gap = LAZY_EIGEN / (p.c_cov * dim)
        # the update's scalar factors (Fig. 4), the same every generation
        self._sigma_path_gain = math.sqrt(p.c_sigma * (2 - p.c_sigma) * p.mu_eff)
        self._cov_path_gain = math.sqrt(p.c_c * (2 - p.c_c) * p.mu_eff)
        self._h_sigma_limit = (1.4 + 2 / (p.dim + 1)) * p.chi_n
        self._c_one = p.c_cov / p.mu_cov
        self._c_mu = p.c_cov - self._c_one
        self._history_len = 10 + math.ceil(30 * dim / p.lam)
        self._best_history: deque[float] = deque(maxlen=self._history_len)
        self._last_f = np.empty(0)
        self._widest = 0  # the coordinate whose std was the largest when last computed (stop test)
        self._scales = self.scale.tolist()

    def _propose(self, n_max: int) -> np.ndarray:
        """Lambda samples of N(m, sigma^2 C), fewer in a last generation cut by the budget."""
        p = cast(StrategyParameters, self.params)  # set by _start
        n = min(p.lam, n_max)
        # mean + sigma (normal D) B^T, in place (the products and sums of the formula, so its values)
        steps = self.rng.standard_normal((n, p.dim))
        steps *= self._D
        steps *= self._sigma
        self._z = steps @ self._B.T
        self._z += self._mean
        self._x = self.from_unit(self._box(self._z) if self.bounds == "transform" else self._z)
        return self._x

    def _learn(self, X: np.ndarray, f: np.ndarray) -> None:
        # bounds="clip": clipped coordinates re-normalised, the others keep their exact sampled value
        z = self._z if self.bounds == "transform" else np.where(X != self._x, self.to_unit(X), self._z)
        order = f.argsort(kind="stable")
        self._last_f = f
        self._best_history.append(float(f[order[0]]))
        mu = cast(StrategyParameters, self.params).mu
        if X.shape[0] >= mu:
            self._update(z[order[:mu]])
            if self.bounds == "transform":
                self._mean = self._box.base_period(self._mean)

    def _update(self, z_sel: np.ndarray) -> None:
        """Fig. 4 update from the mu best normalised candidates z_sel (mu, D), best first.

        p_sigma follows Eq. 11 (Fig. 4 prints mu_eff outside the square root); the rank-mu
        term uses this generation's steps (Eq. 14 prints generation g). The paper does not
        define H_sigma; it is Hansen's: ||p_sigma|| / sqrt(1 - (1 - c_sigma)^(2(g+1)))
        < (1.4 + 2 / (D + 1)) E||N(0, I)||.
        """
        p = cast(StrategyParameters, self.params)
        y = z_sel - self._mean
        y /= self._sigma
        y_w = p.weights @ y
        self._mean = self._mean + self._sigma * y_w
        inv_sqrt_C_y_w = self._B @ ((self._B.T @ y_w) / self._D)
        self._p_sigma = (1 - p.c_sigma) * self._p_sigma + self._sigma_path_gain * inv_sqrt_C_y_w
        self._updates += 1
        norm_p_sigma = math.sqrt(self._p_sigma @ self._p_sigma)
        bias = math.sqrt(1 - (1 - p.c_sigma) ** (2 * self._updates))
        h_sigma = norm_p_sigma / bias < self._h_sigma_limit
        self._p_c = (1 - p.c_c) * self._p_c + h_sigma * self._cov_path_gain * y_w
        rank_one = np.multiply.outer(self._p_c, self._p_c)
        if not h_sigma:  # Hansen's compensation for the p_c update stalled by h_sigma
            rank_one += p.c_c * (2 - p.c_c) * self._C
        # in place, with the products and sums of the formula (so its values)
        C = self._C
        C *= 1 - p.c_cov
        rank_one *= self._c_one
        C += rank_one
        rank_mu = y.T * p.weights
        rank_mu *= self._c_mu
        C += rank_mu @ y
        C += C.T  # symmetric despite rounding
        C /= 2
        self._C = C
        self._sigma *= math.exp(p.c_sigma / p.d_sigma * (norm_p_sigma / p.chi_n - 1))
        if self._updates - self._eigen_updates >= self._eigen_gap:
            eigenvalues, self._B = np.linalg.eigh(self._C)
            self._D = np.sqrt(np.maximum(eigenvalues, 0.0))
            d_min = float(self._D.min())
            self._condition = math.inf if d_min == 0 else float((self._D.max() / d_min) ** 2)
            self._eigen_updates = self._updates

    def _reasons(self) -> dict[str, float]:
        """``tolx`` (largest coordinate std, original units), ``tolfun`` (f range),
        ``conditioncov`` (cond(C))."""
        reasons: dict[str, float] = {}
        if self._updates == 0:
            return reasons
        # one coordinate's std (the largest the last time), the same product as the array's
        # element: at or above tolx, the largest is too and the array is not needed
        j = self._widest
        variance = self._C.item(j, j)
        if not (variance >= 0 and self._sigma * math.sqrt(variance) * self._scales[j] >= self.tolx):
            stds = self._sigma * np.sqrt(self._C.diagonal()) * self.scale
            self._widest = int(stds.argmax())
            std = float(stds.max())
            if std < self.tolx:
                reasons["tolx"] = std
        if len(self._best_history) == self._history_len:
            f_range = max(
                float(self._last_f.max() - self._last_f.min()), max(self._best_history) - min(self._best_history)
            )
            if f_range < self.tolfun:
                reasons["tolfun"] = f_range
        if self._condition > _MAX_CONDITION:
            reasons["conditioncov"] = self._condition
        return reasons
