"""Stage "tracking", continued: detect a lost track from the fitness and recover it.

A frame's search starts from the previous frame's pose and looks in a box around it; once a
limb has slipped out of that box (a leg swapped for the other, an arm stuck at the side),
later frames cannot bring it back, and the error grows over a long sequence. The fitness
shows it: after a slip, the best pose explains the foreground worse than it did.

:class:`Recovery` calls a frame lost when its fitness (0 = perfect match) exceeds
``jump`` times a reference, or exceeds ``max_fitness``. The reference is the lower of the
median fitness of the last ``window`` frames and that of the run's first ``window`` frames:
a sudden slip shows against the first, a slow drift against the second. At most one frame
in ``window`` is searched again, which bounds the extra cost. A lost frame is searched
again: optionally each limb over its whole joint range
(:func:`mmocap.stages.initialisation.search_each_limb`, ``limb_evaluations`` each; 0 by
default: on a 300-frame walk it cost more than it gained), then the full pose in a box
``widen`` times the strategy's (``evaluations``); the better pose is kept. These
evaluations come on top of the frame's budget (they count in its ``evaluations``), and each
recovery is logged and returned (frame, fitness before and after, evaluations) for the
run's ``summary.json``.
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass

import numpy as np

from mmocap.errors import ConfigError
from mmocap.stages.initialisation import search_each_limb
from mmocap.validate import check_flag, check_number

log = logging.getLogger(__name__)


@dataclass
class RecoveryEvent:
    """One recovery: the ``frame``, its fitness before and after, the extra evaluations."""

    frame: int
    fitness_before: float
    fitness_after: float
    evaluations: int

    def summary(self) -> dict:
        """The event as JSON-ready values, fitness rounded to 6 decimals (the run summary's
        ``recoveries``)."""
        return {
            "frame": int(self.frame),
            "fitness_before": round(float(self.fitness_before), 6),
            "fitness_after": round(float(self.fitness_after), 6),
            "evaluations": int(self.evaluations),
        }


class Recovery:
    """Hydra component (``recovery:`` in ``conf/config.yaml``): see the module docstring.

    Args:
        enabled: detect and recover (false: track as the papers do).
        window: frames whose median fitness a frame is compared with, and the fewest frames
            between two recoveries.
        jump: a fitness above this multiple of that median is a lost frame.
        max_fitness: a fitness above this is a lost frame whatever the recent ones.
        limb_evaluations: evaluations of each limb's whole-range search (0: none).
        evaluations: evaluations of the wider full-pose search.
        widen: the wider search box as a multiple of the strategy's.
    """

    def __init__(
        self,
        enabled: bool = True,
        window: int = 10,
        jump: float = 1.3,
        max_fitness: float = 0.3,
        limb_evaluations: int = 0,
        evaluations: int = 1500,
        widen: float = 2.0,
    ):
        self.enabled = check_flag("recovery.enabled", enabled)
        self.window = check_number("recovery.window", window, 1, 10_000, integer=True)
        self.jump = check_number("recovery.jump", jump, 1, low_open=True)
        self.max_fitness = check_number("recovery.max_fitness", max_fitness, 0, 1, low_open=True)
        self.limb_evaluations = check_number("recovery.limb_evaluations", limb_evaluations, 0, 10**7, integer=True)
        if self.limb_evaluations == 1:
            raise ConfigError("recovery.limb_evaluations must be 0 (no limb search) or at least 2, got 1")
        self.evaluations = check_number("recovery.evaluations", evaluations, 2, 10**7, integer=True)
        self.widen = check_number("recovery.widen", widen, 1, 100)
        self.recent: deque[float] = deque(maxlen=self.window)
        self.first: list[float] = []  # the fitness of the run's first frames
        self.since_last = self.window  # frames tracked since the last recovery
        self.events: list[RecoveryEvent] = []  # the recoveries of the run, in order

    def reference(self) -> float:
        """The fitness a frame is compared with (module docstring); NaN before the first frame."""
        if not self.recent:
            return float("nan")
        return min(float(np.median(self.recent)), float(np.median(self.first)))

    def lost(self, fitness: float) -> bool:
        """Whether a frame of ``fitness`` lost the track and may be searched again (never on
        the first frame, nor within ``window`` frames of the last recovery)."""
        if not self.enabled or not self.recent or self.since_last < self.window:
            return False
        return fitness > self.max_fitness or fitness > self.jump * self.reference()

    def keep(self, fitness: float) -> None:
        """Remember the fitness of a frame tracked (or recovered) as a reference of the next."""
        self.recent.append(float(fitness))
        if len(self.first) < self.window:
            self.first.append(float(fitness))
        self.since_last += 1

    def recover(
        self, frame: int, body, x, fitness: float, evaluator, optimizer, strategy, rng
    ) -> tuple[np.ndarray, float, RecoveryEvent]:
        """Search the lost ``frame`` again from its pose ``x`` (51,) of ``fitness``; returns
        (pose, fitness, the event, also appended to :attr:`events`)."""
        limbs_x, limbs_f, used = x, fitness, 0
        if self.limb_evaluations:
            limbs_x, limbs_f, used = search_each_limb(
                strategy, body, x, fitness, evaluator, optimizer, self.limb_evaluations, rng
            )
        wide = type(strategy)(
            rotation_radius=min(np.pi, strategy.rotation_radius * self.widen),
            translation_radius_mm=strategy.translation_radius_mm * self.widen,
            steps=strategy.steps,
        )
        wide_x, wide_f, n = wide.estimate(body, limbs_x, evaluator, optimizer, self.evaluations, rng)
        used += n
        best_x, best_f = (wide_x, wide_f) if wide_f < limbs_f else (limbs_x, limbs_f)
        event = RecoveryEvent(frame, fitness, best_f, used)
        self.events.append(event)
        self.since_last = 0
        log.info(
            "frame %d: fitness %.4f, the track is lost (reference %.4f): searched again with %d evaluations -> %.4f",
            frame,
            fitness,
            self.reference(),
            used,
            best_f,
        )
        return best_x, best_f, event
