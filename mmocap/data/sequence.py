"""On-disk layout of a multi-camera sequence and its reader.

A sequence folder holds::

    sequence.json                 metadata (format, subject, action, fps, frames, cameras,
                                  marker names, subject dimensions, x0, generator settings)
    calibration/<camera>.json     one Camera each (see mmocap.camera; t and world in mm)
    background/<camera>/NNNN.png  frames of the empty scene
    images/<camera>/NNNNNN.png    the sequence (BGR colour or 8-bit greyscale)
    silhouettes/<camera>/NNNNNN.png  true silhouettes, 255 = person (synthetic data only)
    markers_mm.csv                ground-truth markers: frame, marker, x_mm, y_mm, z_mm
    poses.npy                     (frames, 51) ground-truth pose vectors (synthetic only)

``x0`` in ``sequence.json`` is the first frame's pose (51 numbers, mm and rad): the
initialisation the tracker is given, as the papers initialise by hand.

:class:`SequenceBase` is what the pipeline reads from any dataset; :class:`Sequence` reads
this folder layout and :class:`mmocap.data.humaneva.HumanEvaSequence` the HumanEva-I one.
"""
from __future__ import annotations

import json
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from mmocap.camera import Camera
from mmocap.errors import DataError

FORMAT = "mmocap-sequence/1"


def read_image(path: Path, camera: Camera) -> np.ndarray:
    """One image of ``camera``; a missing, unreadable or wrongly sized file is a DataError."""
    if not path.is_file():
        raise DataError(f"camera {camera.name}: image not found: {path}")
    image = cv2.imread(str(path), cv2.IMREAD_COLOR if camera.colour else cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise DataError(f"camera {camera.name}: cannot read image {path}")
    if image.shape[:2] != (camera.height, camera.width):
        raise DataError(f"camera {camera.name}: image {path} is {image.shape[1]}x{image.shape[0]}, "
                        f"calibration says {camera.width}x{camera.height}")
    return image


@dataclass
class SequenceBase(ABC):
    """An opened multi-camera sequence, as the pipeline reads it.

    ``meta`` holds at least ``subject``, ``action``, ``fps``, ``frames``, ``marker_names``
    and ``x0`` (51 numbers, mm and rad); ``cameras`` are the selected cameras, in the order
    of the images that :meth:`images` returns.
    """

    root: Path
    meta: dict
    cameras: list[Camera]

    @property
    def n_frames(self) -> int:
        return int(self.meta["frames"])

    @property
    def fps(self) -> float:
        return float(self.meta["fps"])

    @property
    def subject(self) -> str:
        return str(self.meta["subject"])

    @property
    def x0(self) -> np.ndarray:
        """(51,) first-frame pose (mm, rad)."""
        return np.asarray(self.meta["x0"], dtype=np.float64)

    def check_frame(self, frame: int) -> None:
        if not 0 <= frame < self.n_frames:
            raise DataError(f"frame {frame} outside sequence {self.root} of {self.n_frames} frames")

    @abstractmethod
    def images(self, frame: int) -> list[np.ndarray]:
        """One image per selected camera for ``frame`` (0-based): (H, W, 3) BGR or (H, W)."""

    @abstractmethod
    def background(self, camera: Camera) -> list[np.ndarray]:
        """Frames of the empty scene seen by ``camera``, like its images."""

    @abstractmethod
    def markers(self) -> np.ndarray:
        """(frames, M, 3) ground-truth marker positions in mm, M = len(meta['marker_names']),
        NaN where missing."""


@dataclass
class Sequence(SequenceBase):
    """A sequence folder opened for reading, restricted to ``cameras`` (default: all)."""

    @staticmethod
    def open(root, cameras: list[str] | None = None) -> Sequence:
        root = Path(root)
        meta_path = root / "sequence.json"
        if not meta_path.is_file():
            raise DataError(f"not a sequence folder (no sequence.json): {root}")
        try:
            meta = json.loads(meta_path.read_text())
        except json.JSONDecodeError as exc:
            raise DataError(f"{meta_path} is not valid JSON: {exc}") from None
        if meta.get("format") != FORMAT:
            raise DataError(f"{meta_path}: format '{meta.get('format')}' is not '{FORMAT}'")
        available = meta["cameras"]
        names = list(available) if cameras is None else list(cameras)
        missing = [c for c in names if c not in available]
        if missing:
            raise DataError(f"camera {', '.join(missing)} not in sequence {root} "
                            f"(it has {', '.join(available)})")
        if not names:
            raise DataError("no cameras selected")
        cams = []
        for name in names:
            if not (root / "images" / name).is_dir():
                raise DataError(f"camera {name}: image folder missing: {root / 'images' / name}")
            cams.append(Camera.load(root / "calibration" / f"{name}.json"))
        return Sequence(root, meta, cams)

    def images(self, frame: int) -> list[np.ndarray]:
        self.check_frame(frame)
        return [read_image(self.root / "images" / c.name / f"{frame:06d}.png", c) for c in self.cameras]

    def background(self, camera: Camera) -> list[np.ndarray]:
        folder = self.root / "background" / camera.name
        paths = sorted(folder.glob("*.png"))
        if not paths:
            raise DataError(f"camera {camera.name}: no background frames in {folder}")
        return [read_image(p, camera) for p in paths]

    def silhouette(self, frame: int, camera: Camera) -> np.ndarray:
        """(H, W) bool true silhouette (synthetic sequences only)."""
        path = self.root / "silhouettes" / camera.name / f"{frame:06d}.png"
        mask = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if mask is None:
            raise DataError(f"camera {camera.name}: cannot read silhouette {path}")
        return mask > 127

    def markers(self) -> np.ndarray:
        path = self.root / "markers_mm.csv"
        if not path.is_file():
            raise DataError(f"ground-truth markers not found: {path}")
        table = pd.read_csv(path)
        names = list(self.meta["marker_names"])
        out = np.full((self.n_frames, len(names), 3), np.nan)
        idx = table["marker"].map({n: i for i, n in enumerate(names)})
        if idx.isna().any():
            raise DataError(f"{path}: unknown marker names {sorted(set(table['marker'][idx.isna()]))}")
        out[table["frame"].to_numpy(), idx.to_numpy(int)] = table[["x_mm", "y_mm", "z_mm"]].to_numpy()
        return out


def write_markers(path: Path, markers: np.ndarray, names) -> None:
    """(frames, M, 3) mm -> long-format CSV ``frame, marker, x_mm, y_mm, z_mm``."""
    F, M, _ = markers.shape
    table = pd.DataFrame({
        "frame": np.repeat(np.arange(F), M),
        "marker": np.tile(np.asarray(names), F),
        "x_mm": markers[..., 0].ravel(), "y_mm": markers[..., 1].ravel(), "z_mm": markers[..., 2].ravel(),
    })
    table.to_csv(path, index=False, float_format="%.3f")


class SequenceFolder:
    """Hydra component (``dataset=folder``): an existing sequence folder, read as it is and
    never rendered or changed. ``subject`` names the body preset the tracker uses; it must
    be the sequence's own (``sequence.json``)."""

    def __init__(self, root: str, subject: str = "S1", cameras: list[str] | None = None):
        self.path = Path(root)
        self.subject = subject
        self.cameras = None if cameras is None else list(cameras)

    def open(self, progress: bool = True) -> Sequence:
        return Sequence.open(self.path, self.cameras)
