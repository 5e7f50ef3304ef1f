"""Stage "tracking": frame after frame, search the pose that best explains the foreground.

Each frame starts from the previous frame's estimate (the sequence's ``x0`` for the first
frame) and searches a box of ``rotation_radius`` rad around every active rotation and
``translation_radius_mm`` around the root position, intersected with the joint limits.
The radius doubles as the optimiser's initial step size per coordinate, as in the Yeguas
paper (sigma0 = search radius = 0.5 rad).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from mmocap.api import SearchSpace
from mmocap.errors import ConfigError


@dataclass
class FrameResult:
    """Outcome of one frame: pose (51,) in mm/rad, its fitness, evaluations, wall time."""

    frame: int
    pose: np.ndarray
    fitness: float
    evaluations: int
    seconds: float


class Holistic:
    """All active degrees of freedom searched at once with the whole frame budget."""

    name = "holistic"

    def __init__(self, rotation_radius: float = 0.5, translation_radius_mm: float = 100.0):
        if not 0 < rotation_radius <= np.pi:
            raise ConfigError(f"strategy.rotation_radius must be in (0, pi], got {rotation_radius}")
        if translation_radius_mm <= 0:
            raise ConfigError(f"strategy.translation_radius_mm must be > 0, got {translation_radius_mm}")
        self.rotation_radius = float(rotation_radius)
        self.translation_radius_mm = float(translation_radius_mm)

    def search_space(self, body, x_prev: np.ndarray, budget: int) -> SearchSpace:
        """The box around ``x_prev``'s active coordinates (body.mask) for one search."""
        radius = np.full(x_prev.shape, self.rotation_radius)
        radius[:3] = self.translation_radius_mm
        mask = body.mask
        lower = np.maximum(x_prev - radius, body.lower)[mask]
        upper = np.minimum(x_prev + radius, body.upper)[mask]
        upper = np.maximum(upper, lower + 1e-9)
        x0 = np.clip(x_prev[mask], lower, upper)
        return SearchSpace(x0=x0, lower=lower, upper=upper, sigma0=radius[mask], budget=budget)

    def estimate(self, body, x_prev, evaluate, optimizer, budget, rng) -> tuple[np.ndarray, float, int]:
        """Run ``optimizer`` on the frame; returns (pose (51,), fitness, evaluations)."""
        optimizer.setup(self.search_space(body, x_prev, budget), rng)
        while not optimizer.stop():
            active = optimizer.ask()
            optimizer.tell(active, evaluate(body.full(active, x_prev)))
        result = optimizer.result
        return body.full(result.xbest, x_prev)[0], float(result.fbest), int(result.evaluations)


def check_budget(evaluations) -> None:
    """Reject a per-frame evaluation budget below 1."""
    if evaluations < 1:
        raise ConfigError(f"tracking.evaluations must be >= 1, got {evaluations}")


def track(sequence, body, foreground, evaluator, optimizer, strategy, evaluations: int,
          seed: int, frames: int | None = None, on_frame=None) -> list[FrameResult]:
    """Track ``frames`` frames (default: all) of ``sequence``.

    ``on_frame(result)`` is called after every frame (progress, incremental writing).
    """
    check_budget(evaluations)
    n = sequence.n_frames if frames is None else int(frames)
    if not 1 <= n <= sequence.n_frames:
        raise ConfigError(f"tracking.frames must be in [1, {sequence.n_frames}], got {frames}")
    rng = np.random.default_rng(seed)
    cameras = foreground.cameras
    x_prev = body.clip(sequence.x0[None])[0]
    results = []
    for frame in range(n):
        start = time.perf_counter()
        evaluator.setup(body, cameras, foreground.masks(frame))
        x, f, used = strategy.estimate(body, x_prev, evaluator, optimizer, evaluations, rng)
        result = FrameResult(frame, x, f, used, time.perf_counter() - start)
        results.append(result)
        if on_frame is not None:
            on_frame(result)
        x_prev = x
    return results
