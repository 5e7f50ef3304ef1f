"""HumanEva-I's synchronisation: the ``.ofs`` file of each camera and trial.

The ``.ofs`` indices are 1-based, as in the dataset's MATLAB toolbox, and the mocap index of
image ``i`` is ``MC_ST + (i - IM_ST) * MC_SC`` (MC_SC is about 2: 120 Hz mocap, 60 Hz video).

Toolbox frames: the toolbox numbers a trial's synchronised 60 Hz frames from 1, frame 1 being
the later of the earliest camera's first image and the first mocap frame
(:func:`toolbox_frame_offsets`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mmocap.errors import DataError
from mmocap.io import read_lines_file


@dataclass(frozen=True)
class SyncOffsets:
    """Contents of an ``.ofs`` file: ``IM_ST MC_ST MC_SC`` (1-based image and mocap indices)."""

    image_start: float
    mocap_start: float
    mocap_scale: float

    def mocap_index(self, image_index):
        """1-based image index (scalar or array) -> 1-based, possibly fractional, mocap index."""
        return self.mocap_start + (np.asarray(image_index, float) - self.image_start) * self.mocap_scale

    def image_index(self, mocap_index):
        """Inverse of :meth:`mocap_index`."""
        return self.image_start + (np.asarray(mocap_index, float) - self.mocap_start) / self.mocap_scale

    @staticmethod
    def load(path: Path) -> SyncOffsets:
        """Read an ``.ofs`` file; a DataError naming the file if it is missing, does not hold
        three finite numbers, ``MC_SC`` > 0. A file whose last line has no line end is read as
        HumanEva distributes it, with a warning that it may be cut inside its last number
        (:func:`mmocap.io.check_whole_lines`)."""
        path = Path(path)
        if not path.is_file():
            raise DataError(f"sync file not found: {path}")
        tokens = read_lines_file(path, f"sync file {path}", unended="warn").split()
        try:
            values = [float(t) for t in tokens]
        except ValueError as exc:
            raise DataError(f"sync file {path}: non-numeric value ({exc})") from None
        if len(values) != 3 or not np.all(np.isfinite(values)):
            raise DataError(f"sync file {path} must hold 3 finite numbers (IM_ST MC_ST MC_SC), got {len(values)}")
        if values[2] <= 0:
            raise DataError(f"sync file {path}: MC_SC must be > 0, got {values[2]}")
        return SyncOffsets(*values)

    def save(self, path: Path) -> None:
        """Write the ``.ofs`` file, one number per line, read back exactly by :meth:`load`."""
        Path(path).write_text(f"{self.image_start:.17g}\n{self.mocap_start:.17g}\n{self.mocap_scale:.17g}\n")


def toolbox_frame_offsets(syncs: list[SyncOffsets]) -> np.ndarray:
    """Each camera's 1-based image at toolbox frame 1, numbering a trial's frames as the
    dataset's MATLAB toolbox does (@sync_stream): toolbox frame F (1-based) shows image
    ``offsets[c] + F - 1`` of camera c.  ``syncs``: the trial's ``.ofs`` of its cameras in the
    toolbox's order (C1, C2, C3, BW1..BW4).

    Each camera's (fractional) image at the first camera's MC_ST is shifted so that the
    earliest is image 1, then on to the first mocap frame if that comes later (mocap time
    running at the mean MC_SC), and rounded half up, as MATLAB's ``round``.
    """
    scale = np.mean([s.mocap_scale for s in syncs])
    time = syncs[0].mocap_start
    first = np.array([s.image_index(time) for s in syncs])
    time -= scale * (first.min() - 1)
    first -= first.min() - 1
    if time < 1:
        first += (1 - time) / scale
    return np.floor(first + 0.5).astype(int)
