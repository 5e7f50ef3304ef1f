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
    pose/<camera>_json/           optional 2-D keypoints, OpenPose JSON per frame, or a
      or keypoints.csv            keypoint table (mmocap.data.keypoints)

``x0`` in ``sequence.json`` is the first frame's pose (51 numbers, mm and rad): the
initialisation the tracker is given, as the papers initialise by hand.

Everything is checked when it is read, and a bad file is a :class:`DataError` of one line
naming the file and what is wrong with it: ``sequence.json`` (a JSON object with the keys
of :data:`META_KEYS`, each of its type), every selected camera's calibration (see
:func:`mmocap.camera.checked_camera`), its image folder (every frame present when the
sequence is opened), each image (:func:`read_image`) and ``markers_mm.csv``
(:meth:`Sequence.markers`; a file cut inside a row is refused, and frames lacking markers
are warned about, see :meth:`SequenceBase.ground_truth`).

:class:`SequenceBase` is what the pipeline reads from any dataset; :class:`Sequence` reads
this folder layout and :class:`mmocap.data.humaneva.dataset.HumanEvaSequence` the HumanEva-I one.
"""

from __future__ import annotations

import math
import warnings
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from mmocap.body.model import MARKER_NAMES
from mmocap.body.skeleton import N_FULL
from mmocap.camera import Camera
from mmocap.data.keypoints import AUTO, KeypointFiles
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.io import atomic_writer, read_csv_table, read_json_object
from mmocap.validate import is_integer, is_real

FORMAT = "mmocap-sequence/1"
#: The keys ``sequence.json`` must hold.
META_KEYS = ("format", "subject", "action", "fps", "frames", "cameras", "marker_names", "x0")
#: The columns of ``markers_mm.csv``.
MARKER_COLUMNS = ("frame", "marker", "x_mm", "y_mm", "z_mm")
#: What ``evaluation.missing_markers`` may say about tracked frames that lack ground-truth
#: markers: ``warn`` (a frame lacking any marker is left out of the marker error, warned),
#: ``stop`` (an error naming the frames) or ``score`` (a frame with some markers is scored over
#: those it has, warned; one with none is left out).
MISSING_MARKERS_ACTIONS = ("warn", "stop", "score")
#: Items listed at most in a message (frames, files).
LISTED = 5


def read_image(path: Path, camera: Camera) -> np.ndarray:
    """One image of ``camera``: (H, W, 3) uint8 BGR for a colour camera, (H, W) uint8 for a
    greyscale one.

    The file is read as it is (``cv2.IMREAD_UNCHANGED``) and must be what the calibration
    describes: 8 bits, 3 channels for a colour camera and 1 for a greyscale one, and the
    calibration's size. Nothing is converted: a greyscale file in a colour camera (or the
    reverse) means files of another camera or a wrong ``colour`` in the calibration, and a
    converted image would not be the sensor the background model was fit to. A missing,
    unreadable or mismatched file is a DataError naming the camera and the file.
    """
    if not path.is_file():
        raise DataError(f"camera {camera.name}: image not found: {path}")
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise DataError(f"camera {camera.name}: cannot read image {path} (damaged, or not an image file)")
    if image.dtype != np.uint8:
        raise DataError(
            f"camera {camera.name}: image {path} has {image.dtype} pixels; mmocap reads 8-bit "
            "images (convert it to 8 bits per channel)"
        )
    channels = 1 if image.ndim == 2 else image.shape[2]
    if channels != (3 if camera.colour else 1):
        kind, fix = (
            ("colour", '3-channel BGR images, or set "colour": false in its calibration')
            if camera.colour
            else ("greyscale", '1-channel greyscale images, or set "colour": true in its calibration')
        )
        raise DataError(
            f"camera {camera.name}: image {path} has {channels} channel{'s' * (channels > 1)}, "
            f"but the calibration says camera {camera.name} is {kind}: give it {fix}"
        )
    if image.shape[:2] != (camera.height, camera.width):
        raise DataError(
            f"camera {camera.name}: image {path} is {image.shape[1]}x{image.shape[0]}, "
            f"calibration says {camera.width}x{camera.height}"
        )
    return image


def read_meta(path: Path) -> dict:
    """``sequence.json`` checked: a JSON object with every key of :data:`META_KEYS` of the
    right type (``frames`` a positive integer, ``fps`` a positive number, ``cameras`` and
    ``marker_names`` lists of distinct names, ``marker_names`` those of the body model in its
    order, ``x0`` 51 finite numbers in mm and rad). Errors name the file and the key."""
    if not path.is_file():
        raise DataError(f"not a sequence folder (no sequence.json): {path.parent}")
    meta = read_json_object(
        path, wanted=f"a JSON object with the keys {', '.join(META_KEYS)}", fix="is it truncated or damaged?"
    )
    missing = [key for key in META_KEYS if key not in meta]
    if missing:
        raise DataError(f"{path} lacks the key{'s' * (len(missing) > 1)} {', '.join(missing)}")

    def fail(key: str, wanted: str) -> DataError:
        return DataError(f"{path}: '{key}' must be {wanted}, got {meta[key]!r:.120}")

    if meta["format"] != FORMAT:
        raise fail("format", f"'{FORMAT}'")
    for key in ("subject", "action"):
        if not isinstance(meta[key], str) or not meta[key]:
            raise fail(key, "a non-empty string")
    if not is_integer(meta["frames"]) or meta["frames"] < 1:
        raise fail("frames", "a positive integer")
    if not is_real(meta["fps"]) or not math.isfinite(meta["fps"]) or meta["fps"] <= 0:
        raise fail("fps", "a positive number")
    cameras = meta["cameras"]
    if (
        not isinstance(cameras, list)
        or not cameras
        or not all(isinstance(c, str) and c for c in cameras)
        or len(set(cameras)) != len(cameras)
    ):
        raise fail("cameras", "a non-empty list of distinct camera names")
    if meta["marker_names"] != list(MARKER_NAMES):
        raise fail("marker_names", f"the body model's markers in its order ({', '.join(MARKER_NAMES)})")
    x0 = meta["x0"]
    if not isinstance(x0, list) or len(x0) != N_FULL or not all(is_real(v) for v in x0) or not np.all(np.isfinite(x0)):
        raise fail("x0", f"the first frame's pose: a list of {N_FULL} finite numbers (mm, rad)")
    return meta


def check_missing_markers(action: str) -> str:
    """``action`` if it is one of :data:`MISSING_MARKERS_ACTIONS`, else a ConfigError naming
    ``evaluation.missing_markers``."""
    if action not in MISSING_MARKERS_ACTIONS:
        raise ConfigError(
            f"evaluation.missing_markers must be one of {', '.join(MISSING_MARKERS_ACTIONS)}, got {action!r}"
        )
    return action


def listed(items) -> str:
    """The first :data:`LISTED` of ``items``, comma separated, with how many more."""
    items = [str(i) for i in items]
    more = f" and {len(items) - LISTED} more" if len(items) > LISTED else ""
    return ", ".join(items[:LISTED]) + more


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
        """The number of frames to track."""
        return int(self.meta["frames"])

    @property
    def fps(self) -> float:
        """Frames per second of the cameras."""
        return float(self.meta["fps"])

    @property
    def subject(self) -> str:
        """The subject's body preset (a key of :data:`mmocap.body.mesh.SUBJECTS`)."""
        return str(self.meta["subject"])

    @property
    def x0(self) -> np.ndarray | None:
        """(51,) first-frame pose (mm, rad), or None for a recording that gives none (the
        automatic start, :mod:`mmocap.stages.initialisation`, finds it)."""
        x0 = self.meta["x0"]
        return None if x0 is None else np.asarray(x0, dtype=np.float64)

    def check_frame(self, frame: int) -> None:
        """A DataError naming the sequence unless ``frame`` (0-based) is one of its frames."""
        if not 0 <= frame < self.n_frames:
            raise DataError(f"frame {frame} outside sequence {self.root} of {self.n_frames} frames")

    @abstractmethod
    def images(self, frame: int) -> list[np.ndarray]:
        """One image per selected camera for ``frame`` (0-based): (H, W, 3) BGR or (H, W)."""

    @abstractmethod
    def background(self, camera: Camera) -> list[np.ndarray]:
        """Frames of the empty scene seen by ``camera``, like its images."""

    @property
    def has_background(self) -> bool:
        """True when :meth:`background` has frames of the empty scene (a plate) to give."""
        return True

    @property
    def has_given_masks(self) -> bool:
        """True when :meth:`given_masks` has the person's masks, made by another tool, to give."""
        return False

    def given_masks(self, frame: int) -> list[np.ndarray]:
        """One 8-bit mask image per selected camera for ``frame`` (0-based): (H, W), 255 the
        person; a DataError for a sequence without (:attr:`has_given_masks`)."""
        raise DataError(f"sequence {self.root} has no given masks (masks/<camera>/)")

    @property
    def has_keypoints(self) -> bool:
        """True when :meth:`keypoint_files` has 2-D keypoint files to give."""
        return False

    def keypoint_files(self, skeleton: str = AUTO) -> KeypointFiles:
        """The sequence's 2-D keypoints of :class:`mmocap.data.keypoints.KeypointFiles` (frame
        ``k`` its frame ``k``, its cameras in order), read whole and checked, in ``skeleton`` (a
        name, or ``auto``); a DataError for a sequence without (:attr:`has_keypoints`)."""
        raise DataError(f"sequence {self.root} has no keypoint files (pose/<camera>_json/ or keypoints.csv)")

    @abstractmethod
    def markers(self) -> np.ndarray:
        """(frames, M, 3) ground-truth marker positions in mm, M = len(meta['marker_names']),
        NaN where missing."""

    @property
    @abstractmethod
    def markers_source(self) -> str:
        """The file the ground-truth markers come from, for messages."""

    def ground_truth(self, frames: int, missing_markers: str = "warn") -> np.ndarray:
        """:meth:`markers` of the first ``frames`` frames, (frames, M, 3) mm, after checking
        that each has ground truth: every marker of ``meta['marker_names']`` (M). The run's
        mean error is over the frames that are scored.

        A frame with no marker is never scored; a frame with some (``frame 1 has 7 of 15
        markers``: a file cut short, an occluded marker) is scored only with
        ``missing_markers="score"``, over the markers it has, and is otherwise all NaN in the
        result, so that no mean averages a partial frame. Frames lacking markers are a
        DataError naming the file and the frames with ``missing_markers="stop"``; otherwise
        (``"warn"``, the default as in ``conf/config.yaml``, or ``"score"``) a
        :class:`MmocapWarning` for each kind says which frames and how many are scored.
        """
        check_missing_markers(missing_markers)
        truth = self.markers()[:frames]
        absent = np.isnan(truth).any(axis=2)  # (frames, M): the markers a frame lacks
        empty = np.flatnonzero(absent.all(axis=1))
        partial = np.flatnonzero(absent.any(axis=1) & ~absent.all(axis=1))
        if empty.size == 0 and partial.size == 0:
            return truth
        problems = []
        if empty.size:
            problems.append(
                f"none of the {len(truth)} tracked frames has ground-truth markers"
                if empty.size == len(truth)
                else f"{empty.size} of the {len(truth)} tracked frames (frame{'s' * (empty.size > 1)} "
                f"{listed(empty)}) have no ground-truth markers"
            )
        if partial.size:
            markers = truth.shape[1]
            counts = [f"frame {f} has {markers - absent[f].sum()} of {markers} markers" for f in partial]
            problems.append(listed(counts))
        if missing_markers == "stop":
            raise DataError(
                f"{self.markers_source}: {'; '.join(problems)}; add them, track other frames, or set "
                "evaluation.missing_markers=warn to score only the frames that have them"
            )
        scoring = missing_markers == "score"
        scored = len(truth) - empty.size - (0 if scoring else partial.size)
        over = (
            "no marker error is measured (null in summary.json)"
            if scored == 0
            else f"the marker error is over the {scored} frame{'s' * (scored > 1)} scored"
        )
        if empty.size:
            warnings.warn(f"{self.markers_source}: {problems[0]}: {over}", MmocapWarning, stacklevel=2)
        if partial.size:
            how = (
                "scored over the markers present (evaluation.missing_markers=score)"
                if scoring
                else "not scored, the marker error being over whole frames only "
                "(evaluation.missing_markers=score scores them over the markers present)"
            )
            warnings.warn(f"{self.markers_source}: {problems[-1]}: {how}; {over}", MmocapWarning, stacklevel=2)
            if not scoring:
                truth = truth.copy()
                truth[partial] = np.nan
        return truth


@dataclass
class Sequence(SequenceBase):
    """A sequence folder opened for reading, restricted to ``cameras`` (default: all)."""

    @staticmethod
    def open(root, cameras: list[str] | None = None) -> Sequence:
        """The sequence folder ``root``: its ``sequence.json`` (:func:`read_meta`), and for each
        selected camera its calibration and an image folder with every frame."""
        root = Path(root)
        meta = read_meta(root / "sequence.json")
        available = meta["cameras"]
        names = list(available) if cameras is None else list(cameras)
        missing = [c for c in names if c not in available]
        if missing:
            raise DataError(f"camera {', '.join(missing)} not in sequence {root} (it has {', '.join(available)})")
        if not names:
            raise DataError("no cameras selected")
        cams = []
        for name in names:
            folder = root / "images" / name
            if not folder.is_dir():
                raise DataError(f"camera {name}: image folder missing: {folder}")
            present = {p.name for p in folder.iterdir()}
            absent = [f"{f:06d}.png" for f in range(meta["frames"]) if f"{f:06d}.png" not in present]
            if absent:
                raise DataError(
                    f"camera {name}: {folder} lacks {len(absent)} of the {meta['frames']} frames "
                    f"that {root / 'sequence.json'} gives: {listed(absent)}"
                )
            path = root / "calibration" / f"{name}.json"
            camera = Camera.load(path)
            if camera.name != name:
                raise DataError(
                    f"camera {name}: calibration file {path}: 'name' is {camera.name!r}; "
                    "is it the calibration of another camera?"
                )
            cams.append(camera)
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

    @property
    def has_keypoints(self) -> bool:
        return KeypointFiles.has(self.root)

    def keypoint_files(self, skeleton: str = AUTO) -> KeypointFiles:
        if not self.has_keypoints:
            return super().keypoint_files(skeleton)
        names = [c.name for c in self.cameras]
        return KeypointFiles(self.root, names, self.n_frames, skeleton, calibrated=list(self.meta["cameras"]))

    def silhouette(self, frame: int, camera: Camera) -> np.ndarray:
        """(H, W) bool true silhouette (synthetic sequences only)."""
        path = self.root / "silhouettes" / camera.name / f"{frame:06d}.png"
        mask = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if mask is None:
            raise DataError(f"camera {camera.name}: cannot read silhouette {path}")
        return mask > 127

    @property
    def markers_source(self) -> str:
        return str(self.root / "markers_mm.csv")

    def markers(self) -> np.ndarray:
        return read_markers(Path(self.markers_source), self.n_frames, list(self.meta["marker_names"]))


def read_markers(path: Path, n_frames: int, names: list[str]) -> np.ndarray:
    """(n_frames, M, 3) mm markers of ``names`` (M) from a ``markers_mm.csv``, checked: the
    columns of :data:`MARKER_COLUMNS`, at least one row, integer frames in [0, n_frames),
    known marker names, each (frame, marker) once,
    coordinates that are numbers (an empty cell is a missing coordinate, NaN). Frames
    and markers without a row are NaN. Errors name the file, the column and the line.

    A file cut short inside a row (its last line has no line end) is refused: a cut number
    would be read as another one (:func:`mmocap.io.check_whole_lines`). A file cut at a row's
    end is read as the rows it holds; the frames it lacks, or lacks markers of, are then
    warned about or refused by :meth:`SequenceBase.ground_truth`."""
    if not path.is_file():
        raise DataError(f"ground-truth markers not found: {path}")
    table = read_csv_table(
        path, MARKER_COLUMNS, "one row per frame and marker", skip_blank_lines=False, dtype={"marker": str}
    )
    table = table.dropna(how="all")  # blank lines; the index + 2 stays the line number
    if table.empty:
        raise DataError(f"{path} holds no rows, only its header")

    text = path.read_text(errors="replace").splitlines()

    def line(mask: pd.Series) -> str:
        """The first line where ``mask`` holds, with its text."""
        number = mask.idxmax() + 2
        return f"line {number}: {text[number - 1]:.120}" if number <= len(text) else f"line {number}"

    frames = pd.to_numeric(table["frame"], errors="coerce")
    bad = ~np.isfinite(frames) | (frames != np.round(frames))
    if bad.any():
        raise DataError(f"{path}: column 'frame' must hold integer frame numbers; {line(bad)}")
    frames = frames.astype(int)
    outside = (frames < 0) | (frames >= n_frames)
    if outside.any():
        raise DataError(
            f"{path}: frame {frames[outside.idxmax()]} is outside the sequence's "
            f"{n_frames} frames (0-{n_frames - 1}); {line(outside)}"
        )
    idx = table["marker"].map({n: i for i, n in enumerate(names)})
    if idx.isna().any():
        raise DataError(
            f"{path}: unknown marker names {sorted(set(table['marker'][idx.isna()].astype(str)))} "
            f"(known: {', '.join(names)}); {line(idx.isna())}"
        )
    coordinates = {}
    for column in MARKER_COLUMNS[2:]:
        values = pd.to_numeric(table[column], errors="coerce")
        bad = (values.isna() & table[column].notna()) | np.isinf(values)
        if bad.any():
            raise DataError(f"{path}: column '{column}' must hold numbers in mm (empty = missing); {line(bad)}")
        coordinates[column] = values.to_numpy(np.float64)
    repeated = pd.DataFrame({"frame": frames, "marker": table["marker"]}).duplicated(keep=False)
    if repeated.any():
        first = repeated.idxmax()
        lines = [
            i + 2
            for i in repeated.index[repeated & (frames == frames[first]) & (table["marker"] == table["marker"][first])]
        ]
        raise DataError(
            f"{path}: frame {frames[first]} marker {table['marker'][first]} appears "
            f"{len(lines)} times (lines {listed(lines)}); give each frame and marker one row"
        )
    out = np.full((n_frames, len(names), 3), np.nan)
    out[frames.to_numpy(), idx.to_numpy(int)] = np.stack(list(coordinates.values()), axis=1)
    return out


def write_markers(path: Path, markers: np.ndarray, names) -> None:
    """(frames, M, 3) mm -> long-format CSV ``frame, marker, x_mm, y_mm, z_mm``, written
    atomically; NaN (a missing marker) becomes an empty cell."""
    F, M, _ = markers.shape
    table = pd.DataFrame(
        {
            "frame": np.repeat(np.arange(F), M),
            "marker": np.tile(np.asarray(names), F),
            "x_mm": markers[..., 0].ravel(),
            "y_mm": markers[..., 1].ravel(),
            "z_mm": markers[..., 2].ravel(),
        }
    )
    with atomic_writer(path, "w", newline="") as f:
        table.to_csv(f, index=False, float_format="%.3f")


class SequenceFolder:
    """Hydra component (``dataset=folder``): an existing sequence folder, read as it is and
    never rendered or changed. ``subject`` names the body preset the tracker uses; it must
    be the sequence's own (``sequence.json``)."""

    def __init__(self, root: str, subject: str = "S1", cameras: list[str] | None = None):
        self.path = Path(root)
        self.subject = subject
        self.cameras = None if cameras is None else list(cameras)

    def open(self, progress: bool = True) -> Sequence:
        """The sequence folder, read as it is (``progress`` is unused: nothing is rendered)."""
        return Sequence.open(self.path, self.cameras)
