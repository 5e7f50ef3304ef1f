"""Stage "accuracy": tracking accuracy against ground-truth markers, written to disk.

The error of a frame is Eq. 20 of the Yeguas paper: the mean Euclidean distance in mm
between the estimated and true marker positions, over the markers present (NaN = missing);
a sequence's error is the mean over its frames.
"""

from __future__ import annotations

import contextlib
import csv
import os
from pathlib import Path

import numpy as np

from mmocap.body.skeleton import parameter_names
from mmocap.io import writing


def marker_error(estimated: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(F, M, 3) and (F, M, 3) marker positions in mm -> (F,) mean distance in mm.

    Markers missing in ``truth`` (any NaN coordinate) are skipped; a frame with none
    present gets NaN.
    """
    dist = np.linalg.norm(estimated - truth, axis=-1)
    present = ~np.isnan(dist)
    with np.errstate(invalid="ignore"):
        return np.where(present.any(axis=1), np.nansum(dist, axis=1) / np.maximum(present.sum(axis=1), 1), np.nan)


class FrameLog:
    """Per-frame CSV written row by row and flushed, so that a crash keeps the finished frames.

    Columns: frame, marker_error_mm, fitness, evaluations, seconds, then the 51 pose
    parameters (mm, rad). The rows go to ``<path>.partial`` (``frames.csv.partial``), which
    :meth:`close` renames to ``path`` once every frame is in (the rule of :mod:`mmocap.io`:
    a file appears under its final name only when complete); ``close(complete=False)``, for
    a run that stopped, leaves the rows written so far in ``<path>.partial``. A failure to
    write is a :class:`~mmocap.io.WriteError` naming the file.
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self.partial = self.path.with_name(self.path.name + ".partial")
        with writing(self.partial):
            self.file = open(self.partial, "w", newline="")  # noqa: SIM115  # held until close()
        self.writer = csv.writer(self.file)
        self._write_row(["frame", "marker_error_mm", "fitness", "evaluations", "seconds", *parameter_names()])

    def write(
        self, frame: int, error_mm: float, fitness: float, evaluations: int, seconds: float, pose: np.ndarray
    ) -> None:
        """Append and flush the row of ``frame``: its marker error (mm), fitness, evaluations,
        seconds and (51,) pose (mm, rad)."""
        self._write_row(
            [frame, f"{error_mm:.3f}", f"{fitness:.6f}", evaluations, f"{seconds:.4f}", *(f"{v:.6f}" for v in pose)]
        )

    def _write_row(self, row: list) -> None:
        with writing(self.partial):
            self.writer.writerow(row)
            self.file.flush()

    def close(self, complete: bool = True) -> None:
        """Close the file; with ``complete``, sync it to disk and rename it to ``path``,
        without, keep what was written in ``<path>.partial`` as far as it can be. Closing
        again does nothing."""
        if self.file.closed:
            return
        if not complete:
            with contextlib.suppress(OSError):  # the run has failed already: that error is reported
                self.file.close()
            return
        with writing(self.partial):
            try:
                self.file.flush()
                os.fsync(self.file.fileno())
            finally:
                self.file.close()
            os.replace(self.partial, self.path)
