"""Stage "tracking": frame after frame, search the pose that best explains the foreground.

Each frame starts from the previous frame's estimate (the sequence's ``x0`` for the first
frame) and searches a box of ``rotation_radius`` rad around every active rotation and
``translation_radius_mm`` around the root position, intersected with the joint limits.
The box's half-widths are passed to the optimiser as ``SearchSpace.radius``.

Strategies (Yeguas Sec. 3.3): :class:`Holistic` searches every degree of freedom at once;
:class:`Hierarchical` searches the ``steps`` one after another (by default the paper's six:
root translation and rotation; torso and head; then each limb), each with the coordinates
of the other steps held at their current values.  ``steps`` is data in the config: lists of
joint names that together name each of the 16 joints once ("Root" includes the translation).
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mmocap.api import SearchSpace
from mmocap.body.skeleton import JOINTS
from mmocap.errors import ConfigError
from mmocap.validate import check_number

#: Evaluations of a frame's budget spent on its start pose (the previous frame's estimate).
START_EVALUATIONS = 1

DEFAULT_STEPS = (
    ("Root",),
    ("BottomSpine", "UpperSpine", "Neck"),
    ("LShoulder", "LElbow", "LWrist"),
    ("RShoulder", "RElbow", "RWrist"),
    ("LHip", "LKnee", "LAnkle"),
    ("RHip", "RKnee", "RAnkle"),
)


@dataclass
class FrameResult:
    """Outcome of one frame: pose (51,) in mm/rad, its fitness, evaluations, ``seconds`` of
    wall time spent searching (the evaluator's setup on the frame's masks, the strategy's
    searches, a recovery), and ``foreground_seconds`` spent reading the frame's foreground
    (the images and their background subtraction on a mask-cache miss, a file on a hit).

    ``trace`` (k, 2) float64 is the frame's convergence (:meth:`Trace.rows`): rows
    (evaluations, best fitness so far), the last at ``evaluations`` and, since every built-in
    optimiser reports the best candidate it evaluated, at ``fitness``. ``silhouette_fitness``
    is the pose's silhouette fitness alone when ``fitness`` has a keypoint term too (else None)."""

    frame: int
    pose: np.ndarray
    fitness: float
    evaluations: int
    seconds: float
    foreground_seconds: float = 0.0
    trace: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    silhouette_fitness: float | None = None


class Trace:
    """An evaluator wrapper that records one frame's convergence: the best fitness so far
    against the evaluations spent, counted from 1 in the order the candidates are evaluated
    (the rows of a batch in order), at every candidate better than all before it.

    ``evaluate`` maps candidates (n, 51) to their fitness (n,); only calls are passed on.
    """

    def __init__(self, evaluate):
        self.evaluate = evaluate
        self.evaluations = 0
        self.best = math.inf
        self._improvements: list[np.ndarray] = []  # (m, 2) blocks of (evaluation, fitness)

    def __call__(self, X: np.ndarray) -> np.ndarray:
        fitness = self.evaluate(X)
        values = np.asarray(fitness, dtype=np.float64)  # (n,)
        if values.size and values.min() < self.best:
            best = np.minimum.accumulate(np.r_[self.best, values])  # (n + 1,)
            better = np.flatnonzero(best[1:] < best[:-1])
            self._improvements.append(np.column_stack([self.evaluations + 1 + better, best[1 + better]]))
            self.best = float(best[-1])
        self.evaluations += values.size
        return fitness

    def skip(self, n: int) -> None:
        """Count ``n`` evaluations made at a cheaper fitness (:mod:`mmocap.stages.fidelity`),
        whose values are not comparable with this evaluator's and are not recorded."""
        self.evaluations += int(n)

    def rows(self) -> np.ndarray:
        """(k, 2) float64: (evaluations, best fitness so far) at every improvement, then at
        the last evaluation if it improved nothing; evaluations rise, the fitness never does."""
        rows = np.concatenate(self._improvements) if self._improvements else np.empty((0, 2))
        if self.evaluations and (not len(rows) or rows[-1, 0] < self.evaluations):
            rows = np.vstack([rows, [self.evaluations, self.best]])
        return rows


def joint_indices(joint: str, mask: np.ndarray) -> np.ndarray:
    """Indices into the 51-vector of the active (``mask``) parameters of one joint."""
    j = JOINTS.index(joint)
    idx = np.arange(3 + 3 * j, 6 + 3 * j)
    if j == 0:
        idx = np.r_[0:3, idx]
    return idx[mask[idx]]


class Strategy(ABC):
    """Shared search box, step validation and the ask/tell loop of the strategies."""

    name = "strategy"

    def __init__(self, rotation_radius: float = 0.5, translation_radius_mm: float = 100.0, steps=DEFAULT_STEPS):
        if not 0 < rotation_radius <= np.pi:
            raise ConfigError(f"strategy.rotation_radius must be in (0, pi], got {rotation_radius}")
        if translation_radius_mm <= 0:
            raise ConfigError(f"strategy.translation_radius_mm must be > 0, got {translation_radius_mm}")
        self.rotation_radius = float(rotation_radius)
        self.translation_radius_mm = float(translation_radius_mm)
        self.steps = [list(step) for step in steps]
        named = [joint for step in self.steps for joint in step]
        unknown = sorted(set(named) - set(JOINTS))
        if unknown:
            raise ConfigError(f"strategy.steps name unknown joint(s) {', '.join(unknown)}; joints: {', '.join(JOINTS)}")
        twice = sorted({j for j in named if named.count(j) > 1})
        missing = [j for j in JOINTS if j not in named]
        if twice or missing:
            raise ConfigError(
                f"strategy.steps must name each joint once: repeated {twice or 'none'}, missing {missing or 'none'}"
            )
        if any(not step for step in self.steps):
            raise ConfigError("strategy.steps has an empty step")

    def step_groups(self, body, skip_empty: bool = False) -> list[list[np.ndarray]]:
        """Per step, per joint: indices of the body's active parameters in the 51-vector.

        A step whose joints have no degree of freedom in this body is left out with
        ``skip_empty``, else a ConfigError.
        """
        groups = []
        for k, step in enumerate(self.steps):
            per_joint = [joint_indices(joint, body.mask) for joint in step]
            if sum(len(g) for g in per_joint) == 0:
                if skip_empty:
                    continue
                raise ConfigError(
                    f"strategy step {k + 1} ({', '.join(step)}) has no degree of "
                    f"freedom in the {body.dof}-DOF body model: join it to a step with "
                    "degrees of freedom, or use partition=six (or strategy=holistic)"
                )
            groups.append([g for g in per_joint if len(g)])
        return groups

    @abstractmethod
    def plan(self, body, budget: int) -> list[tuple[list[np.ndarray], int]]:
        """The searches of one frame in order: (partitions, budget) each, a partition being
        an index array into the 51-vector."""

    def check(self, body, optimizer, budget: int) -> None:
        """Raise a ConfigError if a search of the plan gets less than ``optimizer`` needs
        (its ``min_budget(dim, partitions)``, one evaluation for optimisers without one)."""
        budget = check_budget(budget)
        min_budget = getattr(optimizer, "min_budget", lambda dim, partitions=1: 1)
        for k, (parts, share) in enumerate(self.plan(body, budget - START_EVALUATIONS)):
            dim = sum(len(p) for p in parts)
            needed = min_budget(dim, len(parts))
            if share < needed:
                where = f"step {k + 1} ({', '.join(self.steps[k])})" if self.name == "hierarchical" else "the frame"
                raise ConfigError(
                    f"tracking.evaluations={budget} gives {where} {share} evaluations "
                    f"but optimizer '{getattr(optimizer, 'name', type(optimizer).__name__)}' "
                    f"needs at least {needed} for {dim} degrees of freedom"
                )

    def estimate(self, body, x_prev, evaluate, optimizer, budget, rng) -> tuple[np.ndarray, float, int]:
        """Run ``optimizer`` on one frame from ``x_prev`` (51,) following the plan; returns
        (pose (51,), fitness, evaluations used, at most ``budget``).

        The start is evaluated first (one evaluation of the budget), and a search that ends
        worse than the best pose so far leaves it in place: the pose returned is never
        worse than the start.
        """
        self.check(body, optimizer, budget)
        x = np.asarray(x_prev, dtype=np.float64)
        fitness, used = float(evaluate(x[None])[0]), START_EVALUATIONS
        for parts, share in self.plan(body, budget - START_EVALUATIONS):
            found, found_fitness, n = self.search(body, x, parts, evaluate, optimizer, share, rng)
            used += n
            if found_fitness < fitness:
                x, fitness = found, found_fitness
        return x, fitness, used

    def search(self, body, x_base, parts, evaluate, optimizer, budget, rng) -> tuple[np.ndarray, float, int]:
        """Optimise the parameters in ``parts`` (index arrays into the 51-vector) around
        ``x_base`` (51,), the others held fixed; returns (pose (51,), fitness, evaluations).
        """
        indices = np.concatenate(parts)
        radius = np.full(x_base.shape, self.rotation_radius)
        radius[:3] = self.translation_radius_mm
        lower = np.maximum(x_base - radius, body.lower)[indices]
        upper = np.minimum(x_base + radius, body.upper)[indices]
        upper = np.maximum(upper, lower + 1e-9)
        bounds = np.cumsum([0] + [len(p) for p in parts])
        space = SearchSpace(
            x0=np.clip(x_base[indices], lower, upper),
            lower=lower,
            upper=upper,
            radius=radius[indices],
            budget=int(budget),
            partitions=tuple(np.arange(a, b) for a, b in zip(bounds[:-1], bounds[1:])),
        )

        def full(active: np.ndarray) -> np.ndarray:
            X = np.repeat(x_base[None], len(active), axis=0)
            X[:, indices] = active
            return X

        optimizer.setup(space, rng)
        while not optimizer.stop():
            active = optimizer.ask()
            optimizer.tell(active, evaluate(full(active)))
        result = optimizer.result
        return full(np.atleast_2d(result.xbest))[0], float(result.fbest), int(result.evaluations)


class Holistic(Strategy):
    """All active degrees of freedom searched at once with the whole frame budget.

    The steps only become ``SearchSpace.partitions``, for partitioned-sampling optimisers;
    a step without degrees of freedom in the body (``partition=twelve``'s UpperSpine in the
    28-DOF body) is no partition.
    """

    name = "holistic"

    def plan(self, body, budget: int) -> list[tuple[list[np.ndarray], int]]:
        return [([np.concatenate(step) for step in self.step_groups(body, skip_empty=True)], int(budget))]


class Hierarchical(Strategy):
    """The steps searched in order, each with its share of the frame budget.

    Budget split: step k gets ``floor(budget * d_k / D)`` evaluations, d_k being its number
    of active degrees of freedom and D their total; the remainder goes one each to the
    first steps.  Within a step, each joint is one of ``SearchSpace.partitions``.
    """

    name = "hierarchical"

    def budgets(self, groups, budget: int) -> list[int]:
        """The frame's ``budget`` split over the steps ``groups`` in proportion to their number of
        coordinates; the remainder goes one each to the first steps."""
        dofs = np.array([sum(len(g) for g in step) for step in groups])
        shares = budget * dofs // dofs.sum()
        shares[: budget - shares.sum()] += 1
        return shares.tolist()

    def plan(self, body, budget: int) -> list[tuple[list[np.ndarray], int]]:
        groups = self.step_groups(body)
        return list(zip(groups, self.budgets(groups, budget)))


#: the largest per-frame evaluation budget ``tracking.evaluations`` takes
MAX_EVALUATIONS = 10**8


def check_budget(evaluations) -> int:
    """``evaluations`` as an int if it is a per-frame evaluation budget that leaves something
    after the start pose, else a ConfigError naming ``tracking.evaluations`` (150.7 is refused,
    not truncated)."""
    return check_number("tracking.evaluations", evaluations, START_EVALUATIONS + 1, MAX_EVALUATIONS, integer=True)


def frame_views(foreground, keypoints, frame: int) -> tuple[list, Any]:
    """The masks of ``frame`` (C) and its keypoints (None without a ``keypoints`` stream),
    the foreground read once."""
    if keypoints is None:
        return foreground.masks(frame), None
    masks, landmarks = foreground.detections(frame)
    return masks, keypoints.frame(frame, landmarks)


def track(
    sequence,
    body,
    foreground,
    evaluator,
    optimizer,
    strategy,
    evaluations: int,
    seed: int,
    frames: int | None = None,
    on_frame=None,
    coverage=None,
    x0=None,
    rng: np.random.Generator | None = None,
    recovery=None,
    fidelity=None,
    keypoints=None,
) -> list[FrameResult]:
    """Track ``frames`` frames (default: all) of ``sequence`` from the first frame's pose
    ``x0`` ((51,) mm and rad; default: the sequence's).

    ``on_frame(result)`` is called after every frame (progress, incremental writing).
    ``coverage`` (a :class:`mmocap.stages.foreground.ForegroundCoverage`) stops the run
    at, or drops, a camera whose foreground is empty or nearly the whole image. The search
    draws from ``rng`` (default: a generator seeded with ``seed``). ``recovery`` (a
    :class:`mmocap.stages.recovery.Recovery`) searches a frame whose fitness says the track
    is lost again; its evaluations are added to the frame's. ``fidelity`` (a
    :class:`mmocap.stages.fidelity.Fidelity` with levels) spends each frame's first
    evaluations on cheaper fitness levels and its last ``evaluations`` exactly; theirs are
    added to the frame's. ``keypoints`` (a :class:`mmocap.stages.keypoints.KeypointStream`)
    adds each frame's 2-D keypoints to the fitness. Every result's ``trace`` records all of its frame's exact
    evaluations (:class:`Trace`), a recovery's included, and counts the cheaper ones.
    """
    evaluations = check_budget(evaluations)
    n = sequence.n_frames if frames is None else int(frames)
    if not 1 <= n <= sequence.n_frames:
        raise ConfigError(f"tracking.frames must be in [1, {sequence.n_frames}], got {frames}")
    rng = np.random.default_rng(seed) if rng is None else rng
    cameras = foreground.cameras
    names = [cam.name for cam in cameras]
    x0 = sequence.x0 if x0 is None else x0
    if x0 is None:
        raise ConfigError(
            f"sequence {sequence.root} gives no first pose: find one with the automatic start "
            "(start.mode=auto) or give it"
        )
    x_prev = body.clip(np.asarray(x0, dtype=np.float64)[None])[0]
    results = []
    for frame in range(n):
        read = time.perf_counter()
        masks, frame_keypoints = frame_views(foreground, keypoints, frame)
        start = time.perf_counter()
        views = (cameras, masks) if coverage is None else coverage.select(frame, cameras, masks, last_frame=n - 1)
        if frame_keypoints is not None and len(views[0]) < len(cameras):
            frame_keypoints = frame_keypoints.select([names.index(cam.name) for cam in views[0]])
        with_keypoints = {} if frame_keypoints is None else {"keypoints": frame_keypoints}
        evaluator.setup(body, *views, **with_keypoints)
        trace = Trace(evaluator)
        if fidelity is not None and fidelity.enabled:
            fidelity.setup(body, *views, **with_keypoints)
            x, f, used = fidelity.estimate(strategy, body, x_prev, trace, optimizer, evaluations, rng)
        else:
            x, f, used = strategy.estimate(body, x_prev, trace, optimizer, evaluations, rng)
        if recovery is not None:
            if recovery.lost(f):
                x, f, event = recovery.recover(frame, body, x, f, trace, optimizer, strategy, rng)
                used += event.evaluations
            recovery.keep(f)
        silhouettes = None if frame_keypoints is None else float(evaluator.silhouette_fitness(x[None])[0])
        result = FrameResult(frame, x, f, used, time.perf_counter() - start, start - read, trace.rows(), silhouettes)
        results.append(result)
        if on_frame is not None:
            on_frame(result)
        x_prev = x
    if coverage is not None:
        coverage.warn_skipped(n)
    return results
