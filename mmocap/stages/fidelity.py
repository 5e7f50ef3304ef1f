"""Stage "tracking", continued: multi-fidelity search, cheap fitness levels before the exact one.

Most of a frame's evaluations go to candidates far from the optimum, which a coarser
fitness ranks as well as the exact one. :class:`Fidelity` searches each frame first on its
``levels``, each a cheaper fitness: the foreground masks and cameras shrunk by ``scale``
(a mask pixel is foreground when most of the full-size pixels it covers are) and the body
resampled to ``vertices`` skin samples, with ``evaluations`` of its own; then with
``tracking.evaluations`` of the exact fitness (the frame's own evaluator). The frame's pose
and fitness are always the exact fitness's. Two ways:

- ``carry`` (the default, holistic strategy): one search, whose calls go to the levels in
  turn and then to the exact fitness, the optimiser's state (CMA-ES's mean, step size and
  covariance) carrying on; the frame's pose is the best exactly scored candidate, or the
  start if that scores better. An optimiser that ranks within a call, as CMA-ES does, sees
  no jump when the fitness changes.
- restart (``carry: false``, any strategy): a search per level, each from the pose the one
  before found, by the run's optimiser or, with the level's ``optimizer``, one with those
  settings changed (a larger ``popsize`` spreads the per-call costs, which dominate a cheap
  level, over more candidates); the exact search starts from the last level's pose.

Carrying on is the default as it was the more accurate at the same evaluations on the demo
sequence (``mmocap bench fidelity`` compares the two). With no levels (the default) a frame
is searched exactly, as without this stage.

A level's evaluations are counted in the frame's ``evaluations``; its fitness values are
not comparable with the exact ones and stay out of the frame's convergence trace, which
counts them (:meth:`mmocap.stages.tracking.Trace.skip`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from mmocap.errors import ConfigError
from mmocap.validate import check_flag, check_number

#: the smallest image side a level may shrink a camera to, px
MIN_SIDE_PX = 16


@dataclass(frozen=True)
class FidelityLevel:
    """One cheaper fitness: masks and cameras shrunk by ``scale`` (0, 1], the body at
    ``vertices`` skin samples (None: the exact body's), ``evaluations`` per frame, and the
    settings changed in the run's optimiser for this level (``optimizer``, {} for none)."""

    scale: float
    vertices: int | None
    evaluations: int
    optimizer: dict = field(default_factory=dict)


def shrunk_mask(mask: np.ndarray, width: int, height: int) -> np.ndarray:
    """(H, W) bool-like mask -> (height, width) bool: a pixel is foreground when more than
    half of the area it covers in ``mask`` is (OpenCV's area resampling)."""
    area = cv2.resize(np.asarray(mask, bool).astype(np.float32), (width, height), interpolation=cv2.INTER_AREA)
    return area > 0.5


def check_levels(levels) -> list[FidelityLevel]:
    """``fidelity.levels`` from the config (a list of mappings with ``scale``, ``vertices``,
    ``evaluations`` and optionally ``optimizer``) as FidelityLevels; a ConfigError naming the
    level and key otherwise."""
    if levels is None:
        return []
    if isinstance(levels, (str, bytes)) or not hasattr(levels, "__iter__"):
        raise ConfigError(f"fidelity.levels must be a list of {{scale, vertices, evaluations}}, got {levels!r}")
    checked = []
    for k, level in enumerate(levels):
        where = f"fidelity.levels[{k}]"
        if not hasattr(level, "keys"):
            raise ConfigError(f"{where} must be a mapping with scale, vertices and evaluations, got {level!r}")
        unknown = sorted(set(level.keys()) - {"scale", "vertices", "evaluations", "optimizer"})
        if unknown:
            raise ConfigError(
                f"{where} has unknown key(s) {', '.join(map(str, unknown))}: "
                "give scale, vertices, evaluations and optionally optimizer"
            )
        if "evaluations" not in level:
            raise ConfigError(f"{where} needs evaluations (the level's evaluations per frame)")
        scale = check_number(f"{where}.scale", level.get("scale", 1.0), 0, 1, low_open=True)
        vertices = level.get("vertices")
        if vertices is not None:
            vertices = check_number(f"{where}.vertices", vertices, 1000, 200_000, integer=True)
        evaluations = check_number(f"{where}.evaluations", level["evaluations"], 2, 10**8, integer=True)
        settings = level.get("optimizer") or {}
        if not hasattr(settings, "keys"):
            raise ConfigError(
                f"{where}.optimizer must be a mapping of optimiser settings, e.g. {{popsize: 28}}, got {settings!r}"
            )
        checked.append(FidelityLevel(float(scale), vertices, int(evaluations), dict(settings)))
    return checked


class _Switching:
    """An evaluator that sends each call to the first level whose evaluations are not spent
    (``stages``: (evaluator, evaluations) each), then to ``exact`` (a Trace, told of the cheap
    evaluations with ``skip``), and keeps the best exactly scored candidate (``best``: pose,
    fitness)."""

    def __init__(self, stages, exact):
        self.stages, self.exact = stages, exact
        self.evaluations = 0
        self.best = (None, np.inf)

    def __call__(self, X: np.ndarray) -> np.ndarray:
        spent = self.evaluations
        self.evaluations += len(X)
        for evaluator, evaluations in self.stages:
            if spent < evaluations:
                self.exact.skip(len(X))
                return evaluator(X)
            spent -= evaluations
        f = self.exact(X)
        i = int(np.argmin(f))
        if f[i] < self.best[1]:
            self.best = (np.array(X[i], np.float64), float(f[i]))
        return f


class Fidelity:
    """Multi-fidelity search of every frame (see the module's docstring).

    Args:
        levels: the cheaper levels, searched in order before the exact search: mappings with
            ``scale`` (0, 1], ``vertices`` (skin samples, None: the exact body's),
            ``evaluations`` (per frame) and optionally ``optimizer`` (settings changed in the
            run's optimiser); [] (the default) searches exactly only.
        evaluator: a callable returning a new evaluator of the run's backend, one per level
            (the pipeline passes the ``evaluator`` config); required with levels.
        optimizer: a callable returning a new optimiser of the run's kind with the keyword
            settings it is given changed (the pipeline passes the ``optimizer`` config);
            required by a level with ``optimizer`` settings.
        carry: one search carried on over the levels and the exact fitness (True, holistic
            strategy only), or a search per level, restarted (False).
    """

    def __init__(self, levels=(), evaluator=None, optimizer=None, carry: bool = True):
        self.levels = check_levels(levels)
        self.carry = check_flag("fidelity.carry", carry)
        own = [k for k, level in enumerate(self.levels) if level.optimizer]
        if own and self.carry:
            raise ConfigError(
                f"fidelity.levels[{own[0]}].optimizer needs fidelity.carry=false: with carry, one "
                "optimiser carries on over every level"
            )
        if own and optimizer is None:
            raise ConfigError("fidelity.levels with optimizer settings need an optimizer factory")
        self._new_evaluator = evaluator
        if self.levels and evaluator is None:
            raise ConfigError("fidelity.levels needs an evaluator factory for its levels")
        self._optimizers = [optimizer(**level.optimizer) if level.optimizer else None for level in self.levels]
        self._evaluators: list = []
        self._bodies: dict = {}

    def check(self, strategy) -> None:
        """A ConfigError unless ``strategy`` can search these levels: carrying on needs the
        holistic strategy, whose one search spans the frame."""
        if self.levels and self.carry and strategy.name != "holistic":
            raise ConfigError(
                f"fidelity.carry=true needs strategy=holistic (the {strategy.name} strategy "
                "searches its steps one after another): set fidelity.carry=false"
            )

    @property
    def enabled(self) -> bool:
        """True when cheaper levels are configured (else the search is exact only)."""
        return bool(self.levels)

    @property
    def evaluations(self) -> int:
        """Evaluations per frame spent on the cheaper levels."""
        return sum(level.evaluations for level in self.levels)

    def level_body(self, body, vertices: int | None):
        """``body`` resampled to ``vertices`` skin samples (same shape, DOF and seed), made
        once per body and count."""
        if vertices is None or vertices == body.n_vertices:
            return body
        key = (id(body), vertices)
        if key not in self._bodies:
            self._bodies = {k: v for k, v in self._bodies.items() if k[0] == id(body)}  # a new body: forget the old
            self._bodies[key] = body.resampled(vertices)
        return self._bodies[key]

    def setup(self, body, cameras, masks, keypoints=None) -> None:
        """Upload one frame to every level: the body at the level's vertices, C cameras,
        their C (H_c, W_c) masks and their keypoints (or None), shrunk by the level's scale."""
        if not self._evaluators:
            self._evaluators = [self._new_evaluator() for _ in self.levels]
        for level, evaluator in zip(self.levels, self._evaluators):
            small = [cam.shrunk(level.scale, MIN_SIDE_PX) for cam in cameras]
            evaluator.setup(
                self.level_body(body, level.vertices),
                small,
                [shrunk_mask(m, cam.width, cam.height) for m, cam in zip(masks, small)],
                None if keypoints is None else keypoints.on(cameras, small),
            )

    def warm_up(self, body, cameras, masks, x0: np.ndarray) -> None:
        """One untimed evaluation of the start pose x0 (51,) at every level on frame 0 (C
        cameras, C (H_c, W_c) masks), as :meth:`~mmocap.evaluators.timed.TimedEvaluator.warm_up`
        does for the exact fitness: the levels' kernels (a program per culling block size) are
        built before tracking, not in its first frame, whose time they would inflate."""
        if not self.levels:
            return
        self.setup(body, cameras, masks)
        for level, evaluator in zip(self.levels, self._evaluators):
            evaluator(self.level_body(body, level.vertices).clip(np.asarray(x0)[None]))

    def estimate(
        self, strategy, body, x_prev: np.ndarray, exact, optimizer, budget: int, rng
    ) -> tuple[np.ndarray, float, int]:
        """One frame from ``x_prev`` (51,): the levels, then ``budget`` exact evaluations by
        ``exact`` (a :class:`~mmocap.stages.tracking.Trace`, told of the cheap ones);
        returns (pose (51,), its exact fitness, evaluations, the cheap ones included)."""
        if self.carry:
            return self.carried_search(strategy, body, x_prev, exact, optimizer, budget, rng)
        x, cheap = self.search(strategy, body, x_prev, optimizer, rng)
        exact.skip(cheap)
        x, f, used = strategy.estimate(body, x, exact, optimizer, budget, rng)
        return x, f, used + cheap

    def search(self, strategy, body, x_prev: np.ndarray, optimizer, rng) -> tuple[np.ndarray, int]:
        """The cheaper levels in order from ``x_prev`` (51,), each a search of its own:
        returns the last level's pose (51,) and the evaluations they spent."""
        x, used = np.asarray(x_prev, np.float64), 0
        for level, evaluator, own in zip(self.levels, self._evaluators, self._optimizers):
            x, _, n = strategy.estimate(
                self.level_body(body, level.vertices), x, evaluator, own or optimizer, level.evaluations, rng
            )
            used += n
        return x, used

    def carried_search(
        self, strategy, body, x_prev: np.ndarray, exact, optimizer, budget: int, rng
    ) -> tuple[np.ndarray, float, int]:
        """One search over the levels then the exact fitness: the optimiser's state (its
        mean, step size, covariance) carries on from level to level, a call going to the
        level its first candidate falls in. ``exact`` (a :class:`~mmocap.stages.tracking.Trace`)
        scores the last ``budget`` evaluations; the frame's pose is the best of them or the
        start, scored exactly too. Returns (pose (51,), exact fitness, evaluations)."""
        switching = _Switching([(ev, level.evaluations) for level, ev in zip(self.levels, self._evaluators)], exact)
        strategy.estimate(body, x_prev, switching, optimizer, self.evaluations + budget - 1, rng)
        start = float(exact(np.asarray(x_prev, np.float64)[None])[0])
        x, f = switching.best if switching.best[1] < start else (np.asarray(x_prev, np.float64), start)
        return x, f, switching.evaluations + 1

    def close(self) -> None:
        """Close every level's evaluator; the next :meth:`setup` makes new ones."""
        for evaluator in self._evaluators:
            evaluator.close()
        self._evaluators = []
