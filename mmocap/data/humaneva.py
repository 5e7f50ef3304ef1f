"""HumanEva-I (Sigal et al. 2010): a reader of the dataset's own layout, and an exporter that
writes a synthetic sequence in that layout.

Layout under ``root``, as the dataset is distributed::

    S1..S4/Calibration_Data/<cam>.cal              C1, C2, C3 (colour), BW1..BW4 (greyscale)
    S*/Image_Data/<Action>_<Trial>_(<cam>).avi     60 Hz video, or a folder of that name
                                                   holding numbered image files
    S*/Sync_Data/<Action>_<Trial>_(<cam>).ofs      IM_ST MC_ST MC_SC
    S*/Mocap_Data/<Action>_<Trial>.mat             120 Hz markers (withheld for trial 2)
    Background/Background_<k>_(<cam>).avi          empty-scene videos, k = 1, 2, ...

Actions: Walking, Jog, ThrowCatch, Gestures, Box, Combo; trials 1..3 (trial 3 has no video).

Time: the ``.ofs`` indices are 1-based, as in the dataset's MATLAB toolbox, and the mocap
index of image ``i`` is ``MC_ST + (i - IM_ST) * MC_SC`` (MC_SC is about 2: 120 Hz mocap, 60 Hz
video).  Markers at a fractional mocap index are interpolated linearly between the two
nearest mocap frames (NaN if either is missing).  The first selected camera is the
reference: frame k of the opened sequence is its image ``start + k``; every other camera
shows its image nearest the same mocap time, through its own ``.ofs``.

Toolbox frames: the toolbox numbers a trial's synchronised 60 Hz frames from 1, frame 1
being the later of the earliest camera's first image and the first mocap frame
(:func:`toolbox_frame_offsets`), and starts every sequence with video at frame
:data:`TOOLBOX_FIRST_FRAME` (6).  Its Train, Validation and Test partitions
(:data:`PARTITIONS`) are ranges of these frames; ``split`` selects one, else the sequence
runs from the first image at or after toolbox frame 6 at which every mapped marker is
present to the end of the videos.

Ground truth: the ``.mat`` file holds ``Markers`` (mocap frames, labels, 3) in mm, missing
markers being stored as zeros (read as NaN), and the labels under ``ParameterGroup``
POINT/LABELS.  ``marker_map`` (data in ``conf/dataset/humaneva.yaml``) gives, for each of the
body model's markers (:data:`mmocap.body.model.MARKER_NAMES`), the mocap labels whose
centroid stands for it.  The marker error then measures the distance between the model's
skin points and those physical markers: a systematic placement offset (the model's point
is not where the marker was stuck) adds to the tracking error, so figures are comparable
between runs on HumanEva-I, not equal to those of methods scored on HumanEva's virtual
joint centres.

Initialisation (``x0``): either read from a file of 51 numbers (mm, rad), or fitted to the
first frame's markers by :func:`fit_pose` (rigid alignment of the torso markers, then
bounded least squares over the joint angles with a small pull towards the rest pose).
"""
from __future__ import annotations

import contextlib
import os
import re
import shutil
import uuid
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import scipy.io
from omegaconf import OmegaConf
from scipy.optimize import least_squares
from tqdm.auto import tqdm

from mmocap import config
from mmocap.body.model import MARKER_NAMES, BodyModel
from mmocap.body.skeleton import dof_mask
from mmocap.camera import Camera
from mmocap.data.sequence import Sequence, SequenceBase, listed, read_image
from mmocap.errors import ConfigError, DataError
from mmocap.io import incomplete_write, write_image, writing
from mmocap.video import VideoReader

SUBJECTS = ("S1", "S2", "S3", "S4")
ACTIONS = ("Walking", "Jog", "ThrowCatch", "Gestures", "Box", "Combo")
TRIALS = (1, 2, 3)
CAMERAS = ("C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm")
MOCAP_RATE_HZ = 120.0
# The synthetic generator's actions under their HumanEva-I names.
SYNTHETIC_ACTIONS = {"walking": "Walking", "gestures": "Gestures", "boxing": "Box"}
# Markers on the rigid torso, aligned first when fitting x0.
TORSO_MARKERS = ("head", "neck", "pelvis", "l_shoulder", "r_shoulder", "l_hip", "r_hip")
# Pull of every joint angle towards the rest pose in the x0 fit: residual mm per rad.
REST_PULL_MM_PER_RAD = 20.0
# The toolbox's first frame of every sequence with video (1-based toolbox frame): its XviD
# videos repeat their first image, so frames 1-5 are not used (toolbox read-me, v0.8).
TOOLBOX_FIRST_FRAME = 6
SPLITS = ("train", "validation", "test")
# The partitions of HumanEva-I in the dataset's MATLAB toolbox (Sigal, Balan and Black, support
# code v1.1, @he_dataset/he_dataset.m, where validation is called "Validate"; the trial 1 ranges
# agree with facebookresearch/VideoPose3D, data/prepare_data_humaneva.py): (subject, action,
# trial) -> split -> (first, last) toolbox frame, both included (1-based 60 Hz frames, numbered
# as :func:`toolbox_frame_offsets` describes).  The toolbox also puts trial 3 (mocap only, no
# video) into Train as a whole; having no images to read, it is not listed.
PARTITIONS = {
    ("S1", "Walking", 1): {"validation": (6, 590), "train": (591, 1203)},
    ("S1", "Walking", 2): {"test": (6, 1004)},
    ("S1", "Jog", 1): {"validation": (6, 367), "train": (368, 740)},
    ("S1", "Jog", 2): {"test": (6, 874)},
    ("S1", "ThrowCatch", 1): {"validation": (6, 473), "train": (474, 945)},
    ("S1", "ThrowCatch", 2): {"test": (6, 951)},
    ("S1", "Gestures", 1): {"validation": (6, 395), "train": (396, 801)},
    ("S1", "Gestures", 2): {"test": (6, 1070)},
    ("S1", "Box", 1): {"validation": (6, 385), "train": (386, 789)},
    ("S1", "Box", 2): {"test": (6, 606)},
    ("S1", "Combo", 2): {"test": (6, 2602)},
    ("S2", "Walking", 1): {"validation": (6, 438), "train": (439, 876)},
    ("S2", "Walking", 2): {"test": (6, 1093)},
    ("S2", "Jog", 1): {"validation": (6, 398), "train": (399, 795)},
    ("S2", "Jog", 2): {"test": (6, 727)},
    ("S2", "ThrowCatch", 1): {"validation": (6, 550), "train": (551, 1128)},
    ("S2", "ThrowCatch", 2): {"test": (6, 1399)},
    ("S2", "Gestures", 1): {"validation": (6, 500), "train": (501, 901)},
    ("S2", "Gestures", 2): {"test": (6, 1062)},
    ("S2", "Box", 1): {"validation": (6, 382), "train": (383, 734)},
    ("S2", "Box", 2): {"test": (6, 989)},
    ("S2", "Combo", 2): {"test": (6, 2054)},
    ("S3", "Walking", 1): {"validation": (6, 448), "train": (449, 939)},
    ("S3", "Walking", 2): {"test": (6, 805)},
    ("S3", "Jog", 1): {"validation": (6, 401), "train": (402, 842)},
    ("S3", "Jog", 2): {"test": (6, 864)},
    ("S3", "ThrowCatch", 1): {"validation": (6, 493), "train": (494, 1027)},
    ("S3", "ThrowCatch", 2): {"test": (6, 1000)},
    ("S3", "Gestures", 1): {"validation": (6, 533), "train": (534, 1102)},
    ("S3", "Gestures", 2): {"test": (6, 553)},
    ("S3", "Box", 1): {"validation": (6, 512), "train": (513, 1021)},
    ("S3", "Box", 2): {"test": (6, 753)},
    ("S3", "Combo", 2): {"test": (6, 1798)},
    ("S4", "Walking", 2): {"test": (6, 667)},
    ("S4", "Jog", 2): {"test": (6, 590)},
    ("S4", "ThrowCatch", 2): {"test": (6, 773)},
    ("S4", "Gestures", 2): {"test": (6, 459)},
    ("S4", "Box", 2): {"test": (6, 574)},
    ("S4", "Combo", 2): {"test": (6, 1102)},
}


def is_colour(camera: str) -> bool:
    """HumanEva-I's C cameras are colour, its BW cameras greyscale."""
    return not camera.upper().startswith("BW")


def default_marker_map() -> dict[str, list[str]]:
    """The marker map of ``conf/dataset/humaneva.yaml``."""
    return OmegaConf.to_container(config.load("dataset/humaneva.yaml").marker_map)  # type: ignore[return-value]  # a mapping of lists


# --- synchronisation ----------------------------------------------------------------------

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
        path = Path(path)
        if not path.is_file():
            raise DataError(f"sync file not found: {path}")
        tokens = path.read_text(errors="replace").split()
        try:
            values = [float(t) for t in tokens]
        except ValueError as exc:
            raise DataError(f"sync file {path}: non-numeric value ({exc})") from None
        if len(values) != 3 or not np.all(np.isfinite(values)):
            raise DataError(f"sync file {path} must hold 3 finite numbers (IM_ST MC_ST MC_SC), "
                            f"got {len(values)}")
        if values[2] <= 0:
            raise DataError(f"sync file {path}: MC_SC must be > 0, got {values[2]}")
        return SyncOffsets(*values)

    def save(self, path: Path) -> None:
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


# --- images --------------------------------------------------------------------------------

class FrameSource:
    """The images of one camera: a video decoded in order (:class:`mmocap.video.VideoReader`;
    reading backwards decodes from the start again), or a folder of numbered images
    (the k-th file in numerical order being image k, the numbers consecutive).  Indices
    are 1-based.

    Images come out as (H, W, 3) BGR for a colour camera and (H, W) for a greyscale one,
    all of the first image's size.  A greyscale camera's 3-channel frames are converted to
    greyscale, as HumanEva-I's own greyscale videos are stored in colour; a colour camera's
    file must have 3 channels, since colour cannot be recovered from a greyscale image.  A
    gap in the numbers, a file of another size, channel count or depth, or one OpenCV
    cannot read is a DataError naming the camera and the file.
    """

    def __init__(self, path: Path, camera: str, colour: bool):
        self.path, self.camera, self.colour = Path(path), camera, colour
        self._video = None
        self.width = self.height = None
        if self.path.is_dir():
            files = [p for p in self.path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES]
            self.files = sorted(files, key=_frame_number)
            if not self.files:
                raise DataError(f"camera {camera}: no image files in {self.path}")
            _check_numbering(self.files, camera)
            self.count = len(self.files)
        else:
            self.files = None  # type: ignore[assignment]  # a video: no files
            capture = cv2.VideoCapture(str(self.path))
            self.count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
            opened = capture.isOpened()
            capture.release()
            if not opened or self.count < 1:
                raise DataError(f"camera {camera}: cannot read video {self.path}")
            self._video = VideoReader(self.path)
        self.height, self.width = self.read(1).shape[:2]

    def read(self, index: int) -> np.ndarray:
        """Image ``index`` (1-based)."""
        if not 1 <= index <= self.count:
            raise DataError(f"camera {self.camera}: image {index} outside {self.path} "
                            f"({self.count} images)")
        if self.files is not None:
            where = self.files[index - 1]
            image = cv2.imread(str(where), cv2.IMREAD_UNCHANGED)
        else:  # decoded in order: a seek in an XviD file with B-frames can return another frame
            try:
                image = self._video.read(index - 1)
            except DataError as exc:
                raise DataError(f"camera {self.camera}: {exc}") from None
            where = f"{self.path} (image {index})"
        if image is None:
            raise DataError(f"camera {self.camera}: cannot read {where} (damaged, or not an image)")
        channels = 1 if image.ndim == 2 else image.shape[2]
        if image.dtype != np.uint8 or channels not in (1, 3):
            raise DataError(f"camera {self.camera}: {where} has {channels} channels of {image.dtype}; "
                            "mmocap reads 8-bit greyscale or BGR images")
        if self.colour and channels == 1:
            raise DataError(f"camera {self.camera}: {where} is greyscale, but {self.camera} is a colour "
                            "camera: its images must have 3 channels")
        if self.width is not None and image.shape[:2] != (self.height, self.width):
            raise DataError(f"camera {self.camera}: {where} is {image.shape[1]}x{image.shape[0]}, its first "
                            f"image {self.width}x{self.height}")
        return image if self.colour or channels == 1 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)


def _check_numbering(files: list[Path], camera: str) -> None:
    """Image files sorted by :func:`_frame_number` must be numbered consecutively: a gap
    would shift every later image to another time."""
    numbers = [_frame_number(p)[0] for p in files]
    unnumbered = [p.name for p, n in zip(files, numbers) if n < 0]
    if unnumbered:
        raise DataError(f"camera {camera}: {files[0].parent} holds image files without a frame number: "
                        f"{listed(unnumbered)}")
    expected = range(numbers[0], numbers[0] + len(numbers))
    if numbers != list(expected):
        gaps = sorted(set(range(numbers[0], numbers[-1] + 1)) - set(numbers))
        repeats = sorted({n for n in numbers if numbers.count(n) > 1})
        raise DataError(f"camera {camera}: the images in {files[0].parent} are not numbered consecutively "
                        f"(missing: {listed(gaps) or 'none'}, repeated: {listed(repeats) or 'none'}); each image "
                        "must be there once, as the k-th file is taken for image k")


def _frame_number(path: Path) -> tuple[int, str]:
    digits = re.findall(r"\d+", path.stem)
    return (int(digits[-1]) if digits else -1, path.name)


def open_frames(folder: Path, stem: str, camera: str) -> FrameSource:
    """``<folder>/<stem>.avi`` or, failing that, the image folder ``<folder>/<stem>``."""
    video, images = folder / f"{stem}.avi", folder / stem
    if video.is_file():
        return FrameSource(video, camera, is_colour(camera))
    if images.is_dir():
        return FrameSource(images, camera, is_colour(camera))
    raise DataError(f"camera {camera}: image data not found: {video} (nor a folder {images})")


def write_video(path: Path, images, fps: float) -> None:
    """Write 8-bit images ((H, W) or (H, W, 3) BGR) losslessly (FFV1) into an .avi file, and
    read it back: OpenCV's writer does not report a failed write, so a video that holds
    fewer frames is a :class:`~mmocap.io.WriteError` naming it (the disk is full, if it is)."""
    writer, count = None, 0
    for image in images:
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        if writer is None:
            writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), fps,  # type: ignore[attr-defined]
                                     (image.shape[1], image.shape[0]), True)
            if not writer.isOpened():
                raise DataError(f"cannot write video {path}")
        writer.write(image)
        count += 1
    if writer is not None:
        writer.release()
    capture, readable = cv2.VideoCapture(str(path)), 0
    while readable < count and capture.read()[0]:
        readable += 1
    capture.release()
    if readable < count:
        raise incomplete_write(path, f"only {readable} of its {count} frames could be read back")


# --- motion capture ------------------------------------------------------------------------

def _as_list(x) -> list:
    """A value of ``loadmat(simplify_cells=True)`` as a list (single items come unwrapped)."""
    if isinstance(x, list):
        return x
    if isinstance(x, np.ndarray):
        return list(x.ravel())
    return [x]


def read_mocap(path: Path) -> tuple[list[str], np.ndarray]:
    """A HumanEva ``.mat`` marker file -> labels (L,) and (mocap frames, L, 3) mm, NaN = missing.

    Labels lose any ``subject:`` prefix; a marker stored as (0, 0, 0) is missing.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"mocap file not found: {path}")
    try:
        mat = scipy.io.loadmat(str(path), simplify_cells=True)
    except Exception as exc:  # scipy raises many types for a damaged file
        raise DataError(f"cannot read mocap file {path}: {exc}") from None
    markers = np.asarray(mat.get("Markers", np.empty(0)), dtype=np.float64)
    if markers.ndim == 2 and markers.shape[1] == 3:  # a single label comes squeezed
        markers = markers[:, None, :]
    if markers.ndim != 3 or markers.shape[2] != 3 or markers.shape[0] < 1:
        raise DataError(f"mocap file {path}: 'Markers' must be (frames, markers, 3), "
                        f"got shape {markers.shape}")
    labels = None
    for group in _as_list(mat.get("ParameterGroup", [])):
        if isinstance(group, dict) and group.get("name") == "POINT":
            for param in _as_list(group.get("Parameter", [])):
                if isinstance(param, dict) and param.get("name") == "LABELS":
                    labels = [str(x).split(":")[-1].strip() for x in _as_list(param.get("data"))]
    if labels is None:
        raise DataError(f"mocap file {path} has no ParameterGroup POINT/LABELS")
    if len(labels) != markers.shape[1]:
        raise DataError(f"mocap file {path}: {len(labels)} labels for {markers.shape[1]} markers")
    markers[np.all(markers == 0, axis=2)] = np.nan
    return labels, markers


def _cell(items) -> np.ndarray:
    cell = np.empty((1, len(items)), dtype=object)
    for k, item in enumerate(items):
        cell[0, k] = item
    return cell


def _struct_array(records: list[dict]) -> np.ndarray:
    array = np.empty((1, len(records)), dtype=[(key, object) for key in records[0]])
    for k, record in enumerate(records):
        for key, value in record.items():
            array[0, k][key] = value
    return array


def write_mocap(path: Path, labels, markers: np.ndarray, rate_hz: float = MOCAP_RATE_HZ) -> None:
    """(mocap frames, L, 3) mm -> a ``.mat`` file in the structure of HumanEva's: ``Markers``
    with missing (NaN) markers as zeros, and ``ParameterGroup`` POINT with LABELS, RATE,
    UNITS and USED."""
    point = [{"name": _cell(["LABELS"]), "data": _cell(list(labels))},
             {"name": _cell(["RATE"]), "data": float(rate_hz)},
             {"name": _cell(["UNITS"]), "data": _cell(["mm"])},
             {"name": _cell(["USED"]), "data": float(len(labels))}]
    groups = _struct_array([{"name": _cell(["POINT"]), "Parameter": _struct_array(point)}])  # type: ignore[arg-type]
    scipy.io.savemat(str(path), {"Markers": np.nan_to_num(markers, nan=0.0), "ParameterGroup": groups})


def check_marker_map(marker_map: dict) -> dict[str, list[str]]:
    """Every model marker mapped to a non-empty list of labels, no label used twice."""
    marker_map = {str(k): [str(v)] if isinstance(v, str) else [str(x) for x in v]
                  for k, v in dict(marker_map).items()}
    unknown = sorted(set(marker_map) - set(MARKER_NAMES))
    missing = [m for m in MARKER_NAMES if not marker_map.get(m)]
    if unknown or missing:
        raise ConfigError(f"dataset.marker_map must give labels for exactly the markers "
                          f"{', '.join(MARKER_NAMES)}; unknown: {unknown}, without labels: {missing}")
    labels = [label for names in marker_map.values() for label in names]
    if len(labels) != len(set(labels)):
        raise ConfigError("dataset.marker_map uses a mocap label for two markers")
    return marker_map


def model_markers(labels: list[str], markers: np.ndarray, marker_map: dict, path: Path) -> np.ndarray:
    """(mocap frames, L, 3) labelled markers -> (mocap frames, 15, 3) body-model markers, each
    the centroid of its mapped labels (NaN where any of them is missing)."""
    column = {label: k for k, label in enumerate(labels)}
    out = np.empty((markers.shape[0], len(MARKER_NAMES), 3))
    for m, name in enumerate(MARKER_NAMES):
        absent = [label for label in marker_map[name] if label not in column]
        if absent:
            raise DataError(f"mocap file {path} has no marker labelled {', '.join(absent)} "
                            f"(mapped to '{name}' by dataset.marker_map)")
        out[:, m] = markers[:, [column[label] for label in marker_map[name]]].mean(axis=1)
    return out


def sample_mocap(markers: np.ndarray, mocap_index) -> np.ndarray:
    """(mocap frames, M, 3) at 1-based fractional indices (n,) -> (n, M, 3), interpolated
    linearly; NaN outside the recording or where a neighbour is missing."""
    position = np.asarray(mocap_index, float) - 1.0
    low = np.floor(position).astype(int)
    weight = position - low
    high = low + (weight > 0)
    inside = (low >= 0) & (high < len(markers))
    out = np.full((len(position),) + markers.shape[1:], np.nan)
    w = weight[inside, None, None]
    out[inside] = (1 - w) * markers[low[inside]] + w * markers[high[inside]]
    return out


# --- initial pose --------------------------------------------------------------------------

def _rigid_fit(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t minimising |R source + t - target| over (N, 3) points."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    U, _, Vt = np.linalg.svd((source - cs).T @ (target - ct))
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return R, ct - R @ cs


def _euler_of(R: np.ndarray) -> np.ndarray:
    """Angles (a, b, c) in rad with ``Rx(a) @ Ry(b) @ Rz(c) = R``."""
    return np.array([np.arctan2(-R[1, 2], R[2, 2]), np.arcsin(np.clip(R[0, 2], -1, 1)),
                     np.arctan2(-R[0, 1], R[0, 0])])


def fit_pose(body: BodyModel, target: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The pose (51,) whose model markers best match ``target`` (15, 3) mm (NaN = missing).

    Aligns the rest pose's torso markers rigidly to the target's, then solves bounded least
    squares over the ``mask`` entries within the joint limits, each joint angle pulled
    towards the rest pose by :data:`REST_PULL_MM_PER_RAD`.
    """
    present = ~np.isnan(target).any(axis=1)
    anchors = present & np.isin(body.marker_names, TORSO_MARKERS)
    if anchors.sum() < 3:
        raise DataError(f"{anchors.sum()} torso markers present, at least 3 are needed to fit x0")
    x = np.zeros(len(mask))
    R, t = _rigid_fit(body.markers(x[None])[0][anchors], target[anchors])
    x[:3], x[3:6] = t, _euler_of(R)
    free = mask & (body.lower < body.upper)
    angle = free.copy()
    angle[:6] = False

    def residual(v):
        x[free] = v
        return np.r_[(body.markers(x[None])[0] - target)[present].ravel(), REST_PULL_MM_PER_RAD * x[angle]]

    start = np.clip(x[free], body.lower[free], body.upper[free])
    result = least_squares(residual, start, bounds=(body.lower[free], body.upper[free]), x_scale="jac")
    x[free] = result.x
    return x


def read_pose_file(path: Path) -> np.ndarray:
    """(51,) pose (mm, rad) from a .npy file or a text file of 51 numbers."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"x0 file not found: {path}")
    try:
        x = np.load(path) if path.suffix == ".npy" else np.loadtxt(path, delimiter=None, ndmin=1)
    except ValueError as exc:
        raise DataError(f"x0 file {path} is not a list of numbers: {exc}") from None
    x = np.asarray(x, dtype=np.float64).ravel()
    if x.shape != (51,) or not np.all(np.isfinite(x)):
        raise DataError(f"x0 file {path} must hold 51 finite numbers (mm, rad), got {x.size}")
    return x


# --- the sequence and the Hydra component --------------------------------------------------

@dataclass
class HumanEvaSequence(SequenceBase):
    """One HumanEva-I trial opened for reading (see the module docstring for frame timing).

    Extra attributes: ``sources`` (one :class:`FrameSource` per camera), ``image_index``
    (frames, cameras) 1-based image per frame and camera, ``truth`` (frames, 15, 3) mm,
    ``background_sources`` per camera name and ``background_frames`` taken from them.
    """

    sources: list[FrameSource] = field(default_factory=list)
    image_index: np.ndarray = field(default_factory=lambda: np.empty((0, 0), int))
    truth: np.ndarray = field(default_factory=lambda: np.empty((0, len(MARKER_NAMES), 3)))
    background_sources: dict = field(default_factory=dict)
    background_frames: int = 50

    def images(self, frame: int) -> list[np.ndarray]:
        self.check_frame(frame)
        return [src.read(int(i)) for src, i in zip(self.sources, self.image_index[frame])]

    def background(self, camera: Camera) -> list[np.ndarray]:
        sources = self.background_sources[camera.name]
        total = sum(s.count for s in sources)
        picks = np.unique(np.linspace(0, total - 1, min(total, self.background_frames)).round().astype(int))
        starts = np.cumsum([0] + [s.count for s in sources])
        frames = []
        for p in picks:
            k = int(np.searchsorted(starts, p, side="right") - 1)
            frames.append(sources[k].read(int(p - starts[k]) + 1))
        return frames

    def markers(self) -> np.ndarray:
        return self.truth.copy()

    @property
    def markers_source(self) -> str:
        return str(self.root / "Mocap_Data" / f"{self.meta['action']}_{self.meta['trial']}.mat")


class HumanEvaDataset:
    """Hydra component: one trial of HumanEva-I under ``root``.

    Args:
        root: the folder holding ``S1``..``S4`` and ``Background``.
        subject, action, trial: e.g. ``"S1"``, ``"Walking"``, 1.
        cameras: camera names; the first is the timing reference.
        marker_map: body-model marker name -> mocap labels (their centroid is the marker).
        split: None, or the toolbox partition to read (:data:`SPLITS`): exactly its frames of
            :data:`PARTITIONS` for this subject, action and trial.
        start_frame: 1-based image of the first camera to start at, within ``split`` if one is
            given; None = the split's first frame, or without a split the first image from
            toolbox frame :data:`TOOLBOX_FIRST_FRAME` on at which every mapped marker is
            present (the first synchronised one without mocap).
        frames: frames to read at most; None = up to the end of the split, else of the
            shortest video.
        fps: video frame rate (HumanEva-I: 60).
        background_frames: frames taken, evenly spaced, from each camera's background videos.
        min_background_frames: fewer background frames than this is an error.
        x0: file with the first frame's pose (51 numbers, mm and rad); None = fit it to the
            first frame's markers (:func:`fit_pose`) with the ``x0_dof`` model.
        x0_dof: degrees of freedom of the model fitted for x0 (28, 39 or 51).
    """

    def __init__(self, root=None, subject: str = "S1", action: str = "Walking", trial: int = 1,
                 cameras=("C1", "C2", "C3", "BW1"), marker_map: dict | None = None,
                 split: str | None = None, start_frame: int | None = None, frames: int | None = None,
                 fps: float = 60.0, background_frames: int = 50, min_background_frames: int = 2, x0=None,
                 x0_dof: int = 39):
        if root is None:
            raise ConfigError("dataset.root must be set to the HumanEva-I folder (the one holding S1..S4)")
        checks = (("subject", subject, SUBJECTS), ("action", action, ACTIONS), ("trial", trial, TRIALS))
        for name, value, known in checks:
            if value not in known:
                raise ConfigError(f"unknown HumanEva-I {name} {value!r}; known: {', '.join(map(str, known))}")
        cameras = list(cameras)
        unknown = [c for c in cameras if c not in CAMERAS]
        if unknown or not cameras:
            raise ConfigError(f"dataset.cameras must name HumanEva-I cameras ({', '.join(CAMERAS)}), "
                              f"got {cameras}")
        if split is not None and split not in SPLITS:
            raise ConfigError(f"dataset.split must be null or one of {', '.join(SPLITS)}, got {split!r}")
        partitions = PARTITIONS.get((subject, action, int(trial)), {})
        if split is not None and split not in partitions:
            raise ConfigError(f"dataset.split {split!r} has no frames of {subject} {action}_{trial}: the HumanEva-I "
                              f"toolbox's partitions of its video are {', '.join(partitions) or 'none'}; set "
                              "dataset.split to one of them or to null")
        if start_frame is not None and start_frame < 1:
            raise ConfigError(f"dataset.start_frame must be >= 1 (1-based), got {start_frame}")
        if frames is not None and frames < 1:
            raise ConfigError(f"dataset.frames must be >= 1, got {frames}")
        if min_background_frames < 2 or background_frames < min_background_frames:
            raise ConfigError("dataset.background_frames must be >= dataset.min_background_frames >= 2, "
                              f"got {background_frames} and {min_background_frames}")
        self.root, self.subject, self.action, self.trial = Path(root), subject, action, int(trial)
        self.cameras = cameras
        self.marker_map = check_marker_map(default_marker_map() if marker_map is None else marker_map)
        self.split, self.start_frame, self.frames, self.fps = split, start_frame, frames, float(fps)
        self.background_frames, self.min_background_frames = int(background_frames), int(min_background_frames)
        self.x0, self.x0_mask = x0, dof_mask(int(x0_dof))

    @property
    def stem(self) -> str:
        return f"{self.action}_{self.trial}"

    def open(self, progress: bool = True) -> HumanEvaSequence:
        folder = self.root / self.subject
        if not folder.is_dir():
            raise DataError(f"HumanEva-I subject folder not found: {folder}")
        sources, syncs, cams = [], [], []
        for name in tqdm(self.cameras, desc=f"open {self.subject} {self.stem}", unit="camera",
                         disable=not progress):
            source = open_frames(folder / "Image_Data", f"{self.stem}_({name})", name)
            sources.append(source)
            syncs.append(SyncOffsets.load(folder / "Sync_Data" / f"{self.stem}_({name}).ofs"))
            cams.append(Camera.load_cal(folder / "Calibration_Data" / f"{name}.cal", source.width,  # type: ignore[arg-type]
                                        source.height, source.colour))  # type: ignore[arg-type]
        for name, source, sync in zip(self.cameras, sources, syncs):
            if sync.image_start > source.count:
                raise DataError(f"sync file {folder / 'Sync_Data' / f'{self.stem}_({name}).ofs'} starts at "
                                f"image {sync.image_start:g}, past the end of {source.path} "
                                f"({source.count} images)")
        mocap = self._mocap(folder)
        index, truth = self._timing(folder, sources, syncs, mocap)
        x0 = self._initial_pose(truth[0], folder, mocap)
        backgrounds = {c.name: self._background_sources(c.name) for c in cams}
        meta = {
            "format": "humaneva-i", "subject": self.subject, "action": self.action, "trial": self.trial,
            "split": self.split,
            "fps": self.fps, "frames": len(index), "cameras": self.cameras,
            "marker_names": list(MARKER_NAMES), "x0": None if x0 is None else x0.tolist(),
            "first_image": int(index[0, 0]), "marker_map": self.marker_map,
            "units": {"length": "mm", "angle": "rad"},
        }
        return HumanEvaSequence(folder, meta, cams, sources=sources, image_index=index, truth=truth,
                                background_sources=backgrounds, background_frames=self.background_frames)

    def _mocap(self, folder: Path) -> np.ndarray | None:
        """(mocap frames, 15, 3) mm model markers, or None when the trial has no mocap file."""
        path = folder / "Mocap_Data" / f"{self.stem}.mat"
        if not path.is_file():
            return None
        labels, markers = read_mocap(path)
        return model_markers(labels, markers, self.marker_map, path)

    def _timing(self, folder, sources, syncs, mocap):
        """(frames, cameras) 1-based image indices and (frames, 15, 3) mm truth."""
        ref = sources[0]
        candidates = np.arange(1, ref.count + 1)
        mocap_index = syncs[0].mocap_index(candidates)
        per_camera = np.stack([np.rint(s.image_index(mocap_index)).astype(int) for s in syncs], axis=1)
        counts = np.array([s.count for s in sources])
        in_videos = np.all((per_camera >= 1) & (per_camera <= counts), axis=1)
        for c, name in enumerate(self.cameras):
            if not np.any((per_camera[:, c] >= 1) & (per_camera[:, c] <= counts[c])):
                raise DataError(f"sync file {folder / 'Sync_Data' / f'{self.stem}_({name}).ofs'}: no image "
                                f"of {sources[c].path} falls within the reference camera's video")
        offset = self._toolbox_offset(folder) - 1  # toolbox frame F is image F + offset of the reference
        if self.split is None:
            first, last = TOOLBOX_FIRST_FRAME + offset, ref.count
        else:
            span = PARTITIONS[(self.subject, self.action, self.trial)][self.split]
            first, last = (f + offset for f in span)
            if last > ref.count or not in_videos[first - 1:last].all():
                raise DataError(f"dataset.split {self.split!r} is images {first}..{last} of {ref.path} (toolbox "
                                f"frames {span[0]}..{span[1]}), not all of them in every camera's video")
        if self.start_frame is not None:
            start = self.start_frame
            if self.split is not None and not first <= start <= last:
                raise ConfigError(f"dataset.start_frame {start} is outside dataset.split {self.split!r} of "
                                  f"{self.subject} {self.stem}, images {first}..{last} of {self.cameras[0]}; "
                                  "give a start_frame in that range, or null")
            if start > ref.count or not in_videos[start - 1]:
                raise DataError(f"dataset.start_frame {start} is not an image of every camera "
                                f"(the {self.cameras[0]} video {ref.path} has {ref.count})")
        elif self.split is not None:
            start = first
        else:
            usable = in_videos & (candidates >= first)
            if mocap is not None:  # else (trial 2) the first image of every camera
                usable &= ~np.isnan(sample_mocap(mocap, mocap_index)).any(axis=(1, 2))
            if not usable.any():
                markers = ("" if mocap is None else " with every mapped marker present in "
                           f"{folder / 'Mocap_Data' / f'{self.stem}.mat'}")
                raise DataError(f"no image of {ref.path} from image {first} (toolbox frame {TOOLBOX_FIRST_FRAME}) "
                                f"on is in every camera's video{markers}")
            start = int(candidates[np.argmax(usable)])
        run = in_videos[start - 1:last]
        n = int(np.argmin(run)) if not run.all() else len(run)
        if self.frames is not None:
            n = min(n, self.frames)
        rows = slice(start - 1, start - 1 + n)
        truth = (np.full((n, len(MARKER_NAMES), 3), np.nan) if mocap is None
                 else sample_mocap(mocap, mocap_index[rows]))
        return per_camera[rows], truth

    def _toolbox_offset(self, folder: Path) -> int:
        """The reference camera's image at toolbox frame 1, from the ``.ofs`` files of every
        HumanEva-I camera in ``Sync_Data`` (:func:`toolbox_frame_offsets`)."""
        paths = {c: folder / "Sync_Data" / f"{self.stem}_({c}).ofs" for c in CAMERAS}
        present = [c for c, path in paths.items() if path.is_file()]
        offsets = toolbox_frame_offsets([SyncOffsets.load(paths[c]) for c in present])
        return int(offsets[present.index(self.cameras[0])])

    def _initial_pose(self, first_markers: np.ndarray, folder: Path, mocap) -> np.ndarray | None:
        """``dataset.x0``, else the pose fitted to the first frame's markers; None without
        mocap (trial 2: the automatic start finds it)."""
        if self.x0 is not None:
            return read_pose_file(self.x0)
        if mocap is None:
            return None
        if np.isnan(first_markers).any():
            missing = [n for n, row in zip(MARKER_NAMES, first_markers) if np.isnan(row).any()]
            raise DataError(f"{folder / 'Mocap_Data' / f'{self.stem}.mat'}: markers {', '.join(missing)} are "
                            "missing at the first frame; choose another dataset.start_frame or give dataset.x0")
        body = BodyModel(self.subject, dof=int(self.x0_mask.sum()), vertices=None)
        return fit_pose(body, first_markers, self.x0_mask)

    def _background_sources(self, camera: str) -> list[FrameSource]:
        folder = self.root / "Background"
        pattern = re.compile(rf"Background_(\d+)_\({camera}\)(\.avi)?$", re.IGNORECASE)
        found = {p: pattern.match(p.name) for p in folder.glob("Background_*")} if folder.is_dir() else {}
        paths = sorted((p for p, m in found.items() if m and (m.group(2) or p.is_dir())),
                       key=lambda p: int(found[p].group(1)))  # type: ignore[union-attr]  # matched
        if not paths:
            raise DataError(f"camera {camera}: no background video {folder / f'Background_<k>_({camera}).avi'}")
        sources = [FrameSource(p, camera, is_colour(camera)) for p in paths]
        total = sum(s.count for s in sources)
        if total < self.min_background_frames:
            raise DataError(f"camera {camera}: background {', '.join(str(p) for p in paths)} holds {total} "
                            f"frames, the background model needs at least {self.min_background_frames}")
        return sources


# --- exporter ------------------------------------------------------------------------------

def upsample(markers: np.ndarray, factor: int) -> np.ndarray:
    """(F, M, 3) at the video rate -> ((F - 1) * factor + 1, M, 3), linearly interpolated."""
    return sample_mocap(markers, 1 + np.arange((len(markers) - 1) * factor + 1) / factor)


def export(sequence_root, out, marker_map: dict | None = None, trial: int = 1, images: str = "avi",
           mocap_lead: int = 4, progress: bool = True) -> Path:
    """Write a synthetic sequence folder (:mod:`mmocap.data.sequence`) in the HumanEva-I layout.

    Under ``out``: ``<subject>/Calibration_Data``, ``Image_Data`` (lossless FFV1 .avi, or PNG
    folders for ``images="png"``: ``TOOLBOX_FIRST_FRAME - 1`` copies of the first frame, as
    the dataset's videos repeat theirs, then the sequence, which thus starts at the toolbox's
    first frame), ``Sync_Data`` (IM_ST = 1, MC_ST = 1 + mocap_lead, MC_SC = 2),
    ``Mocap_Data/<Action>_<trial>.mat`` (markers at 120 Hz, interpolated from the video rate,
    after ``mocap_lead`` frames with every marker missing and the first frame's markers held
    over the copies; each label of ``marker_map`` at its marker's position) and
    ``Background/Background_1_(<cam>).avi``.
    Returns ``out``. The export completes or leaves ``out`` as it was: a failure to write (a
    :class:`~mmocap.io.WriteError` naming ``out``: a full disk, a read-only folder, a file
    where ``out`` should be) leaves no part of it.
    """
    if images not in ("avi", "png"):
        raise ConfigError(f"images must be 'avi' or 'png', got {images!r}")
    if mocap_lead < 0:
        raise ConfigError(f"mocap_lead must be >= 0, got {mocap_lead}")
    if trial not in TRIALS:
        raise ConfigError(f"unknown HumanEva-I trial {trial!r}; known: {', '.join(map(str, TRIALS))}")
    seq = Sequence.open(sequence_root)
    action = SYNTHETIC_ACTIONS.get(seq.meta["action"])
    if action is None:
        raise ConfigError(f"action '{seq.meta['action']}' of {seq.root} has no HumanEva-I name "
                          f"(known: {', '.join(SYNTHETIC_ACTIONS)})")
    unknown = [c.name for c in seq.cameras if c.name not in CAMERAS]
    if unknown:
        raise ConfigError(f"cameras {', '.join(unknown)} of {seq.root} are not HumanEva-I cameras")
    marker_map = check_marker_map(default_marker_map() if marker_map is None else marker_map)
    out = Path(out)
    stem = f"{action}_{trial}"
    sync = SyncOffsets(1.0, 1.0 + mocap_lead, 2.0)
    lead_in = TOOLBOX_FIRST_FRAME - 1
    subject = Path(seq.subject)
    with _staged_export(out) as staging:
        for cam in tqdm(seq.cameras, desc=f"export {seq.subject} {stem}", unit="camera", disable=not progress):
            cam.save_cal(staging.place(subject / "Calibration_Data" / f"{cam.name}.cal"))
            sync.save(staging.place(subject / "Sync_Data" / f"{stem}_({cam.name}).ofs"))
            frames = (read_image(seq.root / "images" / cam.name / f"{f:06d}.png", cam)
                      for f in [0] * lead_in + list(range(seq.n_frames)))
            video = subject / "Image_Data" / f"{stem}_({cam.name}).avi"
            folder = video.with_suffix("")  # the same images as PNG files; a reader takes the video first
            if images == "avi":
                write_video(staging.place(video, replaces=folder), frames, seq.fps)
            else:
                target = staging.place(folder, replaces=video)
                for f, image in enumerate(frames):
                    write_image(target / f"{f + 1:06d}.png", image)
            write_video(staging.place(Path("Background") / f"Background_1_({cam.name}).avi"),
                        seq.background(cam), seq.fps)
        truth = upsample(seq.markers(), int(sync.mocap_scale))
        truth = np.concatenate([np.full((mocap_lead,) + truth.shape[1:], np.nan),
                                np.repeat(truth[:1], lead_in * int(sync.mocap_scale), axis=0), truth])
        labels = [label for name in MARKER_NAMES for label in marker_map[name]]
        columns = [m for m, name in enumerate(MARKER_NAMES) for _ in marker_map[name]]
        write_mocap(staging.place(subject / "Mocap_Data" / f"{stem}.mat"), labels, truth[:, columns])
    return out


class _Staging:
    """The files of one export, written under a temporary folder inside ``out`` and moved
    into place once every one is written."""

    def __init__(self, out: Path):
        self.out = out
        self.folder = out / f".export-{uuid.uuid4().hex[:12]}.tmp"
        self.entries: list[tuple[Path, Path | None]] = []

    def place(self, relative: Path, replaces: Path | None = None) -> Path:
        """Where to write ``out/relative`` (a file, or a folder of files) for now; its folder
        is made. ``replaces``: another entry under ``out`` that this one makes stale (an
        image folder and a video of the same images), removed when this one moves in."""
        self.entries.append((relative, replaces))
        path = self.folder / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        return path

    def move_into_place(self) -> None:
        """Every entry to its place under ``out``, over a file of an earlier export there; a
        folder there, and the entry it replaces, are removed first."""
        for relative, replaces in self.entries:
            target = self.out / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            stale = [] if replaces is None else [self.out / replaces]
            for path in [target, *stale]:
                if path.is_dir():
                    shutil.rmtree(path)
                elif path in stale:
                    path.unlink(missing_ok=True)
            os.replace(self.folder / relative, target)


@contextlib.contextmanager
def _staged_export(out: Path) -> Iterator[_Staging]:
    """An export that completes or leaves ``out`` as it was: its files are written into a
    temporary folder inside ``out`` and moved into place at the end; on an error the folder
    is removed (and ``out`` too, if the export made it). A file-system fault is a
    :class:`~mmocap.io.WriteError` naming ``out``, as the temporary paths mean nothing to
    the user."""
    made_out = not out.exists()
    staging = _Staging(out)
    try:
        with writing(out, rename=True):
            staging.folder.mkdir(parents=True)
            yield staging
            staging.move_into_place()
    except BaseException:
        if made_out:
            shutil.rmtree(out, ignore_errors=True)
        raise
    finally:
        shutil.rmtree(staging.folder, ignore_errors=True)
