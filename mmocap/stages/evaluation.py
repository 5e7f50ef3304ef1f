"""Stage "evaluation": tracking accuracy against ground-truth markers, written to disk.

The error of a frame is Eq. 20 of the Yeguas paper: the mean Euclidean distance in mm
between the estimated and true marker positions, over the markers present (NaN = missing);
a sequence's error is the mean over its frames.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from mmocap.body.skeleton import parameter_names


def marker_error(estimated: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(F, M, 3) and (F, M, 3) marker positions in mm -> (F,) mean distance in mm.

    Markers missing in ``truth`` (any NaN coordinate) are skipped; a frame with none
    present gets NaN.
    """
    dist = np.linalg.norm(estimated - truth, axis=-1)
    present = ~np.isnan(dist)
    with np.errstate(invalid="ignore"):
        return np.where(present.any(axis=1),
                        np.nansum(dist, axis=1) / np.maximum(present.sum(axis=1), 1), np.nan)


class FrameLog:
    """Per-frame CSV written row by row and flushed, so a crash keeps the finished frames.

    Columns: frame, marker_error_mm, fitness, evaluations, seconds, then the 51 pose
    parameters (mm, rad).
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self.file = open(self.path, "w", newline="")
        self.writer = csv.writer(self.file)
        self.writer.writerow(["frame", "marker_error_mm", "fitness", "evaluations", "seconds",
                              *parameter_names()])

    def write(self, frame: int, error_mm: float, fitness: float, evaluations: int,
              seconds: float, pose: np.ndarray) -> None:
        self.writer.writerow([frame, f"{error_mm:.3f}", f"{fitness:.6f}", evaluations,
                              f"{seconds:.4f}", *(f"{v:.6f}" for v in pose)])
        self.file.flush()

    def close(self) -> None:
        self.file.close()
