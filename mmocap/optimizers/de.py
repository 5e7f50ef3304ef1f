r"""Differential Evolution with role differentiation and malleable mating (Yeguas et al. 2014,
Sec. 4.2.2, Fig. 5, Table 3; Garcia-Martinez et al. 2010) as a batch ask/tell minimiser.

Units. The population lives in normalised coordinates ``z = (x - space.x0) / space.radius``
(one unit = the search radius of each coordinate, rad or mm); candidates returned by
:meth:`DifferentialEvolution.ask` and the result are in the original units. Distances used
by assortative mating are Euclidean in normalised coordinates.

Initial population (generation 0, ``N`` evaluations). Uniform random vectors in the search
space ``[x0 - s * radius, x0 + s * radius]`` intersected with the bounds, where ``s`` is
``init_spread`` (1.0 = the paper's "random vectors within the search space"); with
``include_x0`` the first member is the start point itself.

Generation g (``N`` trials, one per member, all built from the population of generation g):

1. Roles (role differentiation). Sort the population by fitness: P = the ``N_P`` best,
   L = the ``N_L`` best, C = the ``N_C`` worst. Every member ``i`` is a receiving vector R.
2. Placing vector: ``p`` uniform from ``P \ {i}``.
3. Malleable mating: every member carries ``alpha = (alpha_L, alpha_C)`` in [-1, 1]^2 (drawn
   uniformly for generation 0). The placing vector's pair is altered: each component is
   replaced, with probability 0.1, by a new uniform draw from [-1, 1] (the self-adaptation
   rule of jDE, Brest et al. 2006). Fig. 5 only says "alter randomly" and "assortative
   mating"; this encoding of alpha and steps 3-4 are our reading of it.
4. Assortative mating of ``l`` from ``L \ {i, p}`` with ``alpha_L'`` and of ``c`` from
   ``C \ {i, p, l}`` with ``alpha_C'``: draw ``k = 1 + round(|alpha| (m - 1))`` of the ``m``
   candidates at random without replacement and take the one nearest to ``x_p`` if
   ``alpha >= 0`` (positive assortative mating), the farthest if ``alpha < 0`` (negative);
   ``|alpha|`` near 0 is random mating. If a set is empty after the exclusions (small
   ``N_P``, ``N_L`` or ``N_C``), its candidates are the whole population minus the excluded
   members (never empty, as ``N >= 4``).
5. Mutation (Eq. 15): ``v = x_p + F (x_l - x_c)``.
6. Crossover (Eq. 16): ``u[j] = v[j]`` if ``rand <= CR`` or ``j = j_rand``, else ``x_i[j]``;
   ``u`` carries ``alpha'``.
7. Selection: ``u`` (with ``alpha'``) replaces ``x_i`` if ``f(u) <= f(x_i)``.

Steps 1, 2 and 4-7 are Fig. 5 and Eqs. 15-16 as published; ties in step 1 keep the member
order.

Population spread. :meth:`DifferentialEvolution.spread` is the standard deviation of the
population in each coordinate (search radii); the end of every search logs its mean, min
and max at DEBUG level. The spread collapses within a few hundred evaluations, and the role
split of step 1 is the cause, as published: with ``N_P = N_L = N / 2`` the placing and
leading vectors are the same best half and the correcting vectors the worst half, so every
donor is a best-half member moved by F times a worst-to-best difference, and the worst half
never places a donor. Mean spread on the 39-D tracking-like sphere (``x0 = 0``, box +-1,
``radius = 1``, seeds 0-4), initial -> after 1500 evaluations: defaults 0.15 -> 5.5e-4,
Table 3 (cr 0.9, init_spread 1.0, no start point) 0.54 -> 2.0e-6; without the split
(``N_P = N_L = N_C = N``) 0.15 -> 3.2e-3 and 0.54 -> 2.0e-3. On a flat function, with no
selection pressure, the defaults still fall to 8.7e-4 (0.21 without the split): all
fitness values tie, so the same members keep the roles every generation.

Bounds. Trial coordinates outside ``[space.lower, space.upper]`` are clipped to the bound (by
the base class); the clipped, evaluated points enter the population.

Budget. A search needs at least ``N`` evaluations (generation 0). The last generation is
truncated to the evaluations left; only its evaluated trials (those of the first members)
take part in selection, the other members stay as they are.
"""

from __future__ import annotations

import logging
from typing import cast

import numpy as np

from mmocap.optimizers.base import PopulationOptimizer
from mmocap.validate import check_flag, check_number

log = logging.getLogger(__name__)

#: probability that an alpha of the placing vector is redrawn when it is passed on
ALPHA_RESET = 0.1


def assortative_mating(candidates: list[int], Z: np.ndarray, ref: np.ndarray, alpha: float, keys: np.ndarray) -> int:
    """Mate chosen from ``candidates`` (m row indices into the population ``Z`` (N, D)) for
    the reference vector ``ref`` (D,) with mating trend ``alpha`` in [-1, 1]: of
    ``k = 1 + round(|alpha| (m - 1))`` candidates picked at random (those with the k smallest
    of the uniform random ``keys`` (>= m,)), the nearest to ``ref`` if ``alpha >= 0``, the
    farthest if ``alpha < 0``."""
    m = len(candidates)
    k = 1 + int(round(abs(alpha) * (m - 1)))
    pool = np.asarray(candidates)[np.argsort(keys[:m])[:k]]
    dist = np.linalg.norm(Z[pool] - ref, axis=1)
    return int(pool[np.argmin(dist) if alpha >= 0 else np.argmax(dist)])


class DifferentialEvolution(PopulationOptimizer):
    """DE with role differentiation and malleable mating (Fig. 5); see the module docstring.

    Args:
        popsize: N, members of the population and trials per generation (Table 3: 10).
            At least 4.
        n_placing: N_P, placing vectors drawn from the N_P best (Table 3: 5). In [1, N].
        n_leading: N_L, leading vectors drawn from the N_L best (Table 3: 5). In [1, N].
        n_correcting: N_C, correcting vectors drawn from the N_C worst (Table 3: 5). In [1, N].
        cr: CR, crossover rate of Eq. 16 (Table 3: 0.9). In [0, 1].
        f: F, scale of the difference vector of Eq. 15 (Table 3: 0.5). > 0.
        init_spread: half-width of the initial uniform population as a fraction of the
            search radius; 1.0 is the paper (the whole search box). > 0.
        include_x0: make the start point the first member of the initial population (the
            paper does not).

    Defaults are Table 3 except ``cr = 0.5`` (paper 0.9) and ``init_spread = 0.3`` (paper
    1.0), plus the start point. On the demo sequence (S1 walking, 60 frames, 1500
    evaluations, 39 DOF, mean marker error over search seeds 0-2) holistic DE gives 24.6 mm
    with these defaults against 64.6 mm with the paper's (50.0 mm for cr 0.5 with
    ``init_spread`` 1.0, 64.3 mm for cr 0.9 with 0.3): with N = 10 in 39 dimensions the
    population spans at most 9 directions, and a crossover rate of 0.9 confines the trials
    to that span, so the search stalls and the error drifts from frame to frame.
    Hierarchical DE, 6 steps, seed 0: 27.3 mm against 30.1 mm with the paper's values.
    ``include_x0`` matters most: without it the error is several times larger (170 mm
    against 33 mm holistic over 20 frames with the paper's values).
    """

    name = "de"

    def __init__(
        self,
        popsize: int = 10,
        n_placing: int = 5,
        n_leading: int = 5,
        n_correcting: int = 5,
        cr: float = 0.5,
        f: float = 0.5,
        init_spread: float = 0.3,
        include_x0: bool = True,
    ):
        super().__init__()
        self.popsize = check_number("optimizer.popsize", popsize, 4, integer=True)
        self.n_placing = check_number("optimizer.n_placing", n_placing, 1, self.popsize, integer=True)
        self.n_leading = check_number("optimizer.n_leading", n_leading, 1, self.popsize, integer=True)
        self.n_correcting = check_number("optimizer.n_correcting", n_correcting, 1, self.popsize, integer=True)
        self.cr = check_number("optimizer.cr", cr, 0.0, 1.0)
        self.f = check_number("optimizer.f", f, 0.0, low_open=True)
        self.init_spread = check_number("optimizer.init_spread", init_spread, 0.0, low_open=True)
        self.include_x0 = check_flag("optimizer.include_x0", include_x0)

    def population_size(self, dim: int) -> int:
        return self.popsize

    def _start(self) -> None:
        self._Z: np.ndarray | None = None  # (N, D) population, normalised
        self._fit = np.empty(0)  # (N,) its fitness
        self._alpha = self.rng.uniform(-1.0, 1.0, (self.popsize, 2))  # (alpha_L, alpha_C)
        self._trial_alpha = self._alpha

    def _propose(self, n_max: int) -> np.ndarray:
        """Generation 0: the initial population (N, D). Later: N trials, cut to n_max."""
        if self._Z is None:
            lo = np.maximum(self.to_unit(self.lower), -self.init_spread)
            hi = np.minimum(self.to_unit(self.upper), self.init_spread)
            Z = self.rng.uniform(lo, hi, (self.popsize, self.dim))
            if self.include_x0:
                Z[0] = 0.0
            return self.from_unit(Z)
        U, self._trial_alpha = self.trials()
        return self.from_unit(U[:n_max])

    def mates(self) -> tuple[np.ndarray, np.ndarray]:
        """Steps 1-4 for every receiving vector i: indices (N, 3) of its placing, leading and
        correcting vectors, and the altered (alpha_L', alpha_C') (N, 2) of its trial."""
        n, rng = self.popsize, self.rng
        Z = cast(np.ndarray, self._Z)  # evaluated: generation 0 has been told
        order = np.argsort(self._fit, kind="stable").tolist()
        placing, leading, correcting = (
            order[: self.n_placing],
            order[: self.n_leading],
            order[n - self.n_correcting :],
        )
        pick = rng.random(n)
        reset = rng.random((n, 2)) < ALPHA_RESET
        fresh = rng.uniform(-1.0, 1.0, (n, 2))
        keys = rng.random((n, 2, n))
        idx = np.empty((n, 3), dtype=int)
        alpha = np.empty((n, 2))

        def pool(role: list[int], excluded: tuple[int, ...]) -> list[int]:
            left = [j for j in role if j not in excluded]
            return left or [j for j in range(n) if j not in excluded]

        for i in range(n):
            candidates = pool(placing, (i,))
            p = candidates[int(pick[i] * len(candidates))]
            alpha[i] = np.where(reset[i], fresh[i], self._alpha[p])
            ref = Z[p]
            l = assortative_mating(pool(leading, (i, p)), Z, ref, alpha[i, 0], keys[i, 0])
            c = assortative_mating(pool(correcting, (i, p, l)), Z, ref, alpha[i, 1], keys[i, 1])
            idx[i] = p, l, c
        return idx, alpha

    def trials(self) -> tuple[np.ndarray, np.ndarray]:
        """Trial vectors U (N, D), normalised, and their alphas (N, 2): mutation (Eq. 15)
        and binomial crossover (Eq. 16) of every member with its mates."""
        idx, alpha = self.mates()
        Z = cast(np.ndarray, self._Z)
        V = Z[idx[:, 0]] + self.f * (Z[idx[:, 1]] - Z[idx[:, 2]])
        take = self.rng.random(Z.shape) <= self.cr
        take[np.arange(self.popsize), self.rng.integers(0, self.dim, self.popsize)] = True
        return np.where(take, V, Z), alpha

    def spread(self) -> np.ndarray:
        """Standard deviation (D,) of the population in each coordinate, normalised units
        (search radii): about ``init_spread / sqrt(3)`` for the initial population (0.17
        with the defaults, 0.15 with the start point as a member). Available once generation
        0 has been told."""
        if self._Z is None:
            raise RuntimeError("the population is not evaluated yet: tell() generation 0 first")
        return cast(np.ndarray, self._Z.std(axis=0))

    def _learn(self, X: np.ndarray, f: np.ndarray) -> None:
        Z = self.to_unit(X)
        if self._Z is None:
            self._Z, self._fit = Z, f.copy()
        else:
            n = len(f)
            won = f <= self._fit[:n]
            self._Z[:n][won] = Z[won]
            self._fit[:n][won] = f[won]
            self._alpha[:n][won] = self._trial_alpha[:n][won]
        if self.evaluations >= self.budget:
            s = self.spread()
            log.debug(
                "de: population spread after %d evaluations: mean %.3g, min %.3g, "
                "max %.3g search radii over %d coordinates",
                self.evaluations,
                s.mean(),
                s.min(),
                s.max(),
                self.dim,
            )
