"""Annealed particle filter (APF) and partitioned-sampling APF (PSAPF) as batch ask/tell
minimisers (Yeguas et al. 2014, Sec. 4.1.1-4.1.2, Fig. 3, Eq. 6-8, Table 3; Deutscher and
Reid; Bandouch et al.).

Units. Particles live in normalised coordinates ``z = (x - space.x0) / space.radius`` (one
unit = the search radius of each coordinate, rad or mm); asked candidates and the result are
in the original units. The particles are the evaluated (clipped) points.

One annealing layer is one ask/tell round of ``n`` particles:

1. Weighting (Sec. 4.1: pi ∝ 1 - f, with the layer's exponent beta): ``pi_i ∝ (1 -
   f_i)^beta``, normalised; f is the fitness in [0, 1] (0 = perfect), and a particle with
   ``f >= 1`` gets weight 0. For f well below 1 this is ``exp(-beta f)``, Deutscher's form.
2. Annealing rate (Eq. 7-8): beta is the root of ``delta(beta) = 1 / (n sum_i pi_i^2) =
   survival_rate``, found by Brent's method on a bracket grown by doubling. ``delta`` falls
   monotonically from 1 (beta = 0) to k/n (beta -> inf; k particles share the best f); if
   the target is out of that range, beta = 0 (uniform weights over the particles with
   f < 1) or beta = inf (uniform weights over the k best).
3. Resampling: the next layer's particles are drawn with replacement with probabilities pi
   (multinomial, as in Deutscher and Reid).
4. Diffusion (Eq. 6): Gaussian noise of covariance ``c_l P``, where ``P = 1/n sum (z_i -
   zbar)(z_i - zbar)^T`` is the covariance of the resampled particles (Eq. 6, drawn exactly,
   also when P is singular, as ``sqrt(c_l / n) G (Z - zbar)`` with G standard normal) and
   ``c_l = diffusion * survival_rate^(l - 2)`` for layer ``l = 2..L``: the noise shrinks
   with the particles' spread and, on top, geometrically at the survival rate alpha, the
   decay of Deutscher and Reid's layered noise schedule. (A constant c alone, Eq. 6 read
   literally, lets the set grow in high dimension: with delta = 0.5 over 39 coordinates one
   weighting shrinks each coordinate's variance by only ~16%, so beta falls layer by layer.)

First layer. No particle set is carried over between frames (only the previous estimate
``x0``), so layer 1 samples ``z ~ N(0, init_spread^2 I)`` around the start point.

Budget. ``N = budget // L`` particles per layer; the remainder adds one particle to each of
the first layers, so the budget is used exactly. A search needs :data:`MIN_PARTICLES`
particles per layer.

Result. ``result.xbest`` is the best particle evaluated (base class), not the APF's
traditional estimate (the weighted mean of the last layer), because the tracker takes the
result as the pose.

PSAPF (Bandouch et al.): the APF runs on each of ``space.partitions`` in turn (hierarchical
order; None = one partition, i.e. the APF). Every particle is a full pose; the L layers of
partition k diffuse only its coordinates (its first layer adds the ``init_spread`` noise to
them), and the first layer of partition k+1 is resampled from the weighted last layer of
partition k (the weighted resampling between partitions of partitioned sampling).
Budget split: each of the K partitions gets ``MIN_PARTICLES L`` evaluations plus a share of the rest
proportional to its number of coordinates (floor; the remainder one each to the first
partitions), then split over its L layers as above.

Inspection: ``schedule`` lists ``(partition, layer, n)`` for all rounds; per round done,
``betas``, ``survival_rates`` (achieved delta) and ``diffusion_std`` (RMS standard deviation
of the noise added to the round's particles over the diffused coordinates, normalised units).
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from mmocap.api import SearchSpace
from mmocap.errors import ConfigError
from mmocap.optimizers.base import PopulationOptimizer
from mmocap.validate import check_number

#: fewest particles in a layer: with fewer, resampling often draws one particle for every
#: slot, their covariance (Eq. 6) is zero and the layer evaluates identical copies (on the
#: demo, none from 6 particles on). More would refuse psapf on a hierarchical arm step at
#: 1500 evaluations
MIN_PARTICLES = 6


def survival(log_likelihood: np.ndarray, beta: float) -> tuple[float, np.ndarray]:
    """Eq. 7 for weights ``pi ∝ exp(beta * log_likelihood)`` (n,) (-inf = weight 0, at
    least one finite); returns (delta, normalised weights (n,))."""
    finite = np.isfinite(log_likelihood)
    w = np.zeros(len(log_likelihood))
    w[finite] = np.exp(beta * (log_likelihood[finite] - log_likelihood[finite].max()))
    w /= w.sum()
    return float(1.0 / (len(w) * np.sum(w * w))), w


def anneal(f: np.ndarray, target: float) -> tuple[float, float, np.ndarray]:
    """Exponent beta of Eq. 8 for fitness f (n,) in [0, 1] (minimised) and the survival
    rate ``target``; returns (beta, achieved survival rate, weights (n,) ∝ (1 - f)^beta)."""
    g = np.full(len(f), -np.inf)
    ok = f < 1
    if not ok.any():  # no information: every particle survives with equal weight
        return 0.0, 1.0, np.full(len(f), 1.0 / len(f))
    g[ok] = np.log1p(-f[ok])
    gap = g[ok].max() - g[ok]
    low, uniform = survival(g, 0.0)
    if low <= target or not gap.any():
        return 0.0, low, uniform
    if np.count_nonzero(gap == 0) >= target * len(f):
        ties = np.where(np.isfinite(g) & (g == g[ok].max()), 1.0, 0.0)
        return math.inf, float(ties.sum() / len(f)), ties / ties.sum()
    hi = 1.0 / gap.max()
    while survival(g, hi)[0] > target:
        hi *= 2.0
    beta = brentq(lambda b: survival(g, b)[0] - target, 0.0, hi, xtol=1e-12 * hi)
    delta, w = survival(g, beta)
    return float(beta), delta, w


class AnnealedParticleFilter(PopulationOptimizer):
    """Annealed particle filter minimiser (see the module docstring for the rules).

    Args:
        layers: L, annealing layers (ask/tell rounds) per search (per partition for PSAPF).
            Table 3: 10. At least 1.
        survival_rate: alpha, the target particle survival rate delta of Eq. 7-8 and the
            per-layer decay of the diffusion covariance. Sec. 4.1.1: 0.5. In (0, 1).
        init_spread: standard deviation of the first layer around the start point, as a
            fraction of the search radius. > 0.
        diffusion: c, the proportionality constant of Eq. 6 for layer 2 (the noise
            covariance is ``c alpha^(l - 2)`` times the particles' covariance). > 0.
    """

    name = "apf"
    #: search ``space.partitions`` one after another (PSAPF) instead of all at once
    partitioned = False

    def __init__(self, layers: int = 10, survival_rate: float = 0.5, init_spread: float = 0.05, diffusion: float = 1.0):
        super().__init__()
        self.layers = check_number("optimizer.layers", layers, 1, integer=True)
        self.survival_rate = check_number("optimizer.survival_rate", survival_rate, 0, 1, low_open=True, high_open=True)
        self.init_spread = check_number("optimizer.init_spread", init_spread, 0.0, low_open=True)
        self.diffusion = check_number("optimizer.diffusion", diffusion, 0.0, low_open=True)

    def population_size(self, dim: int) -> int:
        """Fewest particles per layer; the actual number is fixed by the budget."""
        return MIN_PARTICLES

    def min_budget(self, dim: int, partitions: int = 1) -> int:
        """``MIN_PARTICLES`` in each of the L layers (of each partition for PSAPF)."""
        return self.population_size(dim) * self.layers * (partitions if self.partitioned else 1)

    def _start(self) -> None:
        parts = cast(SearchSpace, self._space).partitions  # set by setup
        if not self.partitioned or parts is None:
            parts = (np.arange(self.dim),)
        parts = tuple(np.asarray(p, dtype=int) for p in parts)
        if any(len(p) == 0 for p in parts) or not np.array_equal(np.sort(np.concatenate(parts)), np.arange(self.dim)):
            raise ConfigError("search space partitions must be non-empty and cover each coordinate once")
        self._parts = parts
        self.schedule = self._split_budget([len(p) for p in parts])
        self._round = 0
        self._Z = np.zeros((1, self.dim))  # the start point, weight 1
        self._w = np.ones(1)
        self.betas: list[float] = []
        self.survival_rates: list[float] = []
        self.diffusion_std: list[float] = []

    def _split_budget(self, dims: ArrayLike) -> list[tuple[int, int, int]]:
        """(partition, layer, particles) of every round: per partition ``MIN_PARTICLES L`` plus a share of
        the rest proportional to its dimension, per layer an equal share; remainders one
        each to the first partitions and layers."""
        L = self.layers
        dims = np.asarray(dims)
        spare = self.budget - self.min_budget(self.dim, len(dims))
        shares = MIN_PARTICLES * L + spare * dims // dims.sum()
        shares[: self.budget - shares.sum()] += 1
        return [(k, l, int(share // L + (l < share % L))) for k, share in enumerate(shares) for l in range(L)]

    def _propose(self, n_max: int) -> np.ndarray:
        part, layer, n = self.schedule[self._round]
        idx = self._parts[part]
        Z = self._Z[self.rng.choice(len(self._w), size=n, p=self._w)]
        if layer == 0:
            noise = self.init_spread * self.rng.standard_normal((n, len(idx)))
            std = self.init_spread
        else:
            scale = self.diffusion * self.survival_rate ** (layer - 1)
            centred = Z[:, idx] - Z[:, idx].mean(axis=0)
            noise = math.sqrt(scale / n) * self.rng.standard_normal((n, n)) @ centred
            std = math.sqrt(scale * np.mean(centred**2))
        Z[:, idx] += noise
        self.diffusion_std.append(std)
        return self.from_unit(Z)

    def _learn(self, X: np.ndarray, f: np.ndarray) -> None:
        beta, delta, self._w = anneal(f, self.survival_rate)
        self._Z = self.to_unit(X)
        self.betas.append(beta)
        self.survival_rates.append(delta)
        self._round += 1


class PartitionedAnnealedParticleFilter(AnnealedParticleFilter):
    """Partitioned-sampling APF (Bandouch et al.): the APF on each of ``space.partitions`` in
    hierarchical order, weighted resampling between them; same arguments as
    :class:`AnnealedParticleFilter`, ``layers`` per partition. A search needs ``MIN_PARTICLES L K``
    evaluations for K partitions."""

    name = "psapf"
    partitioned = True
