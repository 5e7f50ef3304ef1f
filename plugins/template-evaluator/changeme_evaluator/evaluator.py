# TEMPLATE: rename the class ChangemeChunkedEvaluator and its name changeme-chunked (also in
# pyproject.toml, conf/evaluator/changeme-chunked.yaml and tests/), then put your own code
# where the comments say.
"""An evaluator backend: the silhouette fitness of candidate poses, computed by the rule of
:mod:`mmocap.evaluators.silhouette` (its docstring is the specification). Every backend
must give the same pixel counts as the ``naive`` reference, exactly; the conformance suite
checks it.

A subclass of :class:`mmocap.evaluators.silhouette.SilhouetteEvaluator` (or, as here, of
one of its backends) inherits the checks of the inputs, the fitness from the counts
(Cano Eq. 6-7) and the lifecycle (``setup`` per frame, ``close``, context manager), and
implements:

- ``_prepare()``: per-frame work after ``setup`` stored ``self.body``, ``self.cameras``
  and ``self.foreground`` (C bool masks): build tables, upload them to a device;
- ``_counts(X)``: checked poses (n, P), n >= 1 -> ``|M_c|`` and ``|M_c & F_c|``, (n, C)
  int64 each;
- ``_render(x, camera_index)``: one pose (P,) -> the (H, W) bool model silhouette.

This example splits the population into chunks of at most ``chunk`` candidates and counts
each with the numpy backend: the place where a backend of your own (a device, a pool of
workers) would count a batch.
"""

from __future__ import annotations

import numpy as np

from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.evaluators.silhouette import PATCH_SCALE
from mmocap.validate import check_number


class ChangemeChunkedEvaluator(NumpyEvaluator):
    """The numpy backend, called on at most ``chunk`` candidates at a time.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.
        chunk: candidates counted per call of the numpy backend (>= 1).
    """

    name = "changeme-chunked"  # the entry-point name
    # Set these for a backend of your own (see mmocap.api.Evaluator):
    owns_cores = False  # its threads or workers keep every core busy during a call
    starts_processes = False  # it starts worker processes (a sweep then runs it in-process)

    @classmethod
    def unavailable(cls) -> str | None:
        """Why this backend cannot run here (a missing library or device, and what to
        install), or None; ``mmocap list`` shows it."""
        return None

    # Every default here is the one of conf/evaluator/changeme-chunked.yaml (the tests check it).
    def __init__(self, patch_scale: float = PATCH_SCALE, chunk: int = 64):
        super().__init__(patch_scale)
        self.chunk = check_number("evaluator.chunk", chunk, 1, integer=True)

    def _prepare(self) -> None:
        super()._prepare()  # your own: per-frame tables, device buffers

    def _counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        count = super()._counts  # your own: count a batch of candidates here
        parts = [count(X[i : i + self.chunk]) for i in range(0, len(X), self.chunk)]
        return np.concatenate([m for m, _ in parts]), np.concatenate([o for _, o in parts])

    # _render(x, camera_index) is the numpy backend's; write your own with _counts.

    def close(self) -> None:
        super().close()  # your own: release workers or device buffers; close() is idempotent
