"""An evaluator wrapper that measures the time spent evaluating candidates."""

from __future__ import annotations

import time

import numpy as np


class TimedEvaluator:
    """An evaluator that adds up the wall time spent evaluating candidates (``seconds``)."""

    def __init__(self, evaluator):
        self.evaluator = evaluator
        self.seconds = 0.0

    def warm_up(self, body, cameras, masks, x0: np.ndarray) -> None:
        """One untimed evaluation of the start pose (51,) on frame 0's ``masks`` seen by
        ``cameras``, so that building kernels, starting worker pools and filling caches do not
        count as tracking time."""
        self.evaluator.setup(body, cameras, masks)
        self.evaluator(body.clip(np.asarray(x0)[None]))

    def __call__(self, X: np.ndarray) -> np.ndarray:
        start = time.perf_counter()
        try:
            return self.evaluator(X)
        finally:
            self.seconds += time.perf_counter() - start

    def __getattr__(self, name):
        return getattr(self.evaluator, name)
