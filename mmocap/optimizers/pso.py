"""Particle Swarm Optimisation with an exponentially decreasing inertia weight (Yeguas et al.
2014, Sec. 4.2.3, Fig. 6, Eq. 17-19, Table 3; John et al. 2010) as a batch ask/tell minimiser.

Units. Positions and velocities live in normalised coordinates ``z = (x - space.x0) /
space.radius`` (one unit = the search radius of each coordinate, rad or mm); candidates
returned by :meth:`ParticleSwarm.ask` and the result are in the original units.

Initial swarm (generation 0, ``N`` evaluations). Positions uniform in the search space
``[x0 - s * radius, x0 + s * radius]`` intersected with the bounds and velocities uniform in
``[-s, s]`` per coordinate, where ``s`` is ``init_spread`` (1.0 = the paper's random
positions in the search space); with ``include_x0`` the first particle starts at the start
point. Each particle's best ``p_i`` is its start position.

Generation g = 1 .. G, G = ceil(budget / N) - 1 (the moves the budget allows):

1. Velocity (Eq. 18): ``v_i = w_g v_i + phi1 r1 (p_i - x_i) + phi2 r2 (b - x_i)``, with
   ``r1, r2`` uniform in [0, 1] drawn per particle and coordinate and ``b`` the best position
   the swarm has ever evaluated (global-best topology); each component is then clamped to
   ``[-v_max, v_max]`` when ``v_max`` is set (Fig. 6 lists v_max, Table 3 gives no value).
2. Position (Eq. 17): ``x_i = x_i + v_i``. Bounds: a coordinate that leaves
   ``[space.lower, space.upper]`` is set to the bound and its velocity component to 0.
3. Evaluate; ``p_i`` and ``b`` are replaced by strictly better points.

Inertia (Eq. 19). ``w_g = w_max / e^(c_g)``: ``c`` starts at 0 for the first move and grows
by ``Delta c = ln(w_max / w_min) / g_max`` after each move, with ``g_max = G - 1`` the number
of inertia changes, so the first move uses ``w_max`` and the last move the budget allows
``w_min`` (one move only: ``w_max``). With ``w_min = 0.1`` (Table 3),
``ln(w_max / w_min) = ln(10 w_max)``, exactly Eq. 19's range of ``c``.

Budget. A search needs at least ``N`` evaluations (generation 0). The last generation is
truncated to the evaluations left: only its first particles move; the others keep their
position and velocity.
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np

from mmocap.errors import ConfigError
from mmocap.optimizers.base import PopulationOptimizer
from mmocap.validate import check_flag, check_number


def inertia_schedule(w_max: float, w_min: float, moves: int) -> np.ndarray:
    """Inertia weight (moves,) of Eq. 19 for moves 1 .. ``moves``: ``w_max`` decreasing
    exponentially to ``w_min``, reached at the last move."""
    if moves <= 1:
        return np.full(max(moves, 0), w_max)
    delta_c = math.log(w_max / w_min) / (moves - 1)
    return cast(np.ndarray, w_max / np.exp(delta_c * np.arange(moves)))


class ParticleSwarm(PopulationOptimizer):
    """PSO with the inertia weight of Eq. 19 (Fig. 6); see the module docstring.

    Args:
        popsize: N, particles (Table 3: 10). At least 2.
        phi1: weight of the particle's own best in Eq. 18 (Table 3: 2.0). >= 0.
        phi2: weight of the swarm's best in Eq. 18 (Table 3: 2.0). >= 0.
        w_max: inertia weight of the first move (Table 3: 2.0). > 0.
        w_min: inertia weight of the last move (Table 3: 0.1). In (0, w_max].
        v_max: largest velocity component as a fraction of the search radius, or None for
            no clamping (Table 3 gives no value). > 0.
        init_spread: half-width of the initial positions and velocities as a fraction of
            the search radius; 1.0 is the paper (the whole search box). > 0.
        include_x0: start the first particle at the start point (the paper does not).

    Defaults are Table 3 except ``v_max = 0.1`` and ``init_spread = 0.1`` (0.05 rad, 10 mm),
    chosen on the demo sequence (S1 walking, 20 frames, mean marker error): holistic 1500
    evaluations 24.2 mm with the paper's start (1.0, no clamp) against 15.5 mm; 22.5 mm with
    ``init_spread = 0.03`` and no clamp (``w_max = 2`` blows the swarm up); 0.03/0.03 gives
    13.4 mm holistic and 11.5 vs 11.8 mm hierarchical, but 28.9 vs 19.9 mm hierarchical at
    500 evaluations, where a step has only a few moves.
    """

    name = "pso"

    def __init__(
        self,
        popsize: int = 10,
        phi1: float = 2.0,
        phi2: float = 2.0,
        w_max: float = 2.0,
        w_min: float = 0.1,
        v_max: float | None = 0.1,
        init_spread: float = 0.1,
        include_x0: bool = True,
    ):
        super().__init__()
        self.popsize = check_number("optimizer.popsize", popsize, 2, integer=True)
        self.phi1 = check_number("optimizer.phi1", phi1, 0.0)
        self.phi2 = check_number("optimizer.phi2", phi2, 0.0)
        self.w_max = check_number("optimizer.w_max", w_max, 0.0, low_open=True)
        self.w_min = check_number("optimizer.w_min", w_min, 0.0, low_open=True)
        if self.w_min > self.w_max:
            raise ConfigError(f"optimizer.w_min must be <= optimizer.w_max ({self.w_max}), got {self.w_min}")
        self.v_max = None if v_max is None else check_number("optimizer.v_max", v_max, 0.0, low_open=True)
        self.init_spread = check_number("optimizer.init_spread", init_spread, 0.0, low_open=True)
        self.include_x0 = check_flag("optimizer.include_x0", include_x0)

    def population_size(self, dim: int) -> int:
        return self.popsize

    def _start(self) -> None:
        self.moves = 0  # velocity updates done
        self.inertia = math.nan  # w of the latest move
        self.schedule = inertia_schedule(self.w_max, self.w_min, math.ceil(self.budget / self.popsize) - 1)
        self._zlo, self._zhi = self.to_unit(self.lower), self.to_unit(self.upper)
        self._Z: np.ndarray | None = None  # (N, D) positions, normalised
        self._V = np.empty(0)  # (N, D) velocities, normalised
        self._P = np.empty(0)  # (N, D) particle bests
        self._pfit = np.empty(0)  # (N,) their fitness

    def _propose(self, n_max: int) -> np.ndarray:
        """Generation 0: the initial positions (N, D). Later: the moved swarm, cut to n_max."""
        s = self.init_spread
        if self._Z is None:
            Z = self.rng.uniform(np.maximum(self._zlo, -s), np.minimum(self._zhi, s), (self.popsize, self.dim))
            if self.include_x0:
                Z[0] = 0.0
            self._new_V = self.rng.uniform(-s, s, Z.shape)
            return self.from_unit(Z)
        self.inertia = float(self.schedule[self.moves])
        r1 = self.rng.random(self._Z.shape)
        r2 = self.rng.random(self._Z.shape)
        best = self._P[np.argmin(self._pfit)]
        V = self.inertia * self._V + self.phi1 * r1 * (self._P - self._Z) + self.phi2 * r2 * (best - self._Z)
        if self.v_max is not None:
            V = np.clip(V, -self.v_max, self.v_max)
        Z = self._Z + V
        out = (Z < self._zlo) | (Z > self._zhi)
        Z = np.clip(Z, self._zlo, self._zhi)
        self._new_V = np.where(out, 0.0, V)
        return self.from_unit(Z[:n_max])

    def _learn(self, X: np.ndarray, f: np.ndarray) -> None:
        Z = self.to_unit(X)
        n = len(f)
        if self._Z is None:
            self._Z, self._V = Z, self._new_V
            self._P, self._pfit = Z.copy(), f.copy()
            return
        self.moves += 1
        self._Z[:n] = Z
        self._V[:n] = self._new_V[:n]
        better = f < self._pfit[:n]
        self._P[:n][better] = Z[better]
        self._pfit[:n][better] = f[better]
