"""Stage "foreground": the person's mask per frame and camera, undistorted, and its cache.

Where each frame's mask comes from is ``foreground.method`` (:func:`choose_method`):

- ``plate``: background subtraction (:mod:`mmocap.stages.background`, ``background=...``), one
  model per camera fit on the empty scene (the plate);
- ``segmentation``: person segmentation (:mod:`mmocap.stages.segmentation`), which needs no
  plate and also finds 33 2-D landmarks of the person;
- ``masks``: the person's masks given with a recording (``masks/<camera>/`` or
  ``masks/<camera>.mp4``, made by any tool), used as they are;
- ``auto`` (the default): the given masks if the recording holds them, else the plate if the
  sequence has one, else person segmentation. :func:`choose_method` says which, and why.

Each camera's model maps an input image to ``(mask, landmarks)`` (:meth:`find_person`): the
mask in the image's own, distorted geometry, and (33, 3) landmarks or None. The undistortion
stage then remaps the mask once with the camera's maps, computed once per camera by
``cv2.initUndistortRectifyMap`` (:meth:`mmocap.camera.Camera.undistort_mask`). From there on
the cameras are ideal pin-holes, ``camera.ideal()``: the Cano paper's approach (Sec. 3.2),
which undistorts the foreground once per frame and never the model's vertices.

The masks are :class:`ForegroundMask` arrays: (H, W) bool that also carry their row-packed
bits (the layout the OpenCL evaluator uploads) and ``|F|``.

Cache: one ``.npz`` per frame holding every camera's packed bits (and its landmarks, where the
method finds them, under ``<camera>.landmarks``), in ``<cache_dir>/<key>/NNNNNN.npz``, ``key``
being a digest of the method's configuration and of the sequence: its folder, metadata,
calibrations, the pixels of its background frames (for the plate) and, where there is one,
the modification time of its ``sequence.json`` (which a re-rendered sequence rewrites). A
changed configuration or sequence thus reads and writes another folder; files are written to
a temporary name and renamed, so an interrupted run never leaves a partial one. The default
``cache_dir`` is ``outputs/cache/foreground`` (relative to the working directory, like the
runs), which keeps datasets read-only. Given masks are read as they are, never cached.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import warnings
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from mmocap.bitmask import ForegroundMask, unpack_rows
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.io import atomic_writer
from mmocap.stages import segmentation
from mmocap.stages.background import Cleanup
from mmocap.validate import check_choice, check_number

log = logging.getLogger(__name__)
CACHE_FORMAT = 1  # bump when the masks of a given configuration change meaning
DEFAULT_CACHE_DIR = Path("outputs/cache/foreground")
#: the values of ``foreground.method``
METHODS = ("auto", "plate", "segmentation", "masks")
#: a given mask's pixel is the person's above this grey level (masks in lossy videos blur)
GIVEN_MASK_LEVEL = 127
#: a mask region at least this fraction of the largest one's area (and of PERSON_MIN_FRACTION of
#: the image) counts as a second person
SECOND_PERSON_RATIO = 0.25
#: the smallest region, as a fraction of the image, that can be a person
PERSON_MIN_FRACTION = 0.002


class GivenMask:
    """One camera's given masks (``foreground.method=masks``): an 8-bit mask image (0 the
    scene, 255 the person, as segmentation tools write them) -> (H, W) bool, cleaned up.

    The keyword arguments are those of :class:`~mmocap.stages.background.Cleanup`; the default
    changes nothing, since the masks are used as they are.
    """

    needs_plate = False
    reads = "masks"
    finds_landmarks = False

    def __init__(self, open_px: int = 0, close_px: int = 0, min_area_px: int = 0, largest_only: bool = False):
        self.cleanup = Cleanup(open_px, close_px, min_area_px, largest_only)

    def find_person(self, image: np.ndarray, name: str | None = None) -> tuple[np.ndarray, None]:
        """(H, W) or (H, W, 3) mask image -> ((H, W) bool mask, no landmarks)."""
        image = np.asarray(image)
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
        return self.cleanup(grey > GIVEN_MASK_LEVEL), None


def choose_method(
    sequence, method: str, make_background: Callable, make_segmenter: Callable, make_given: Callable = GivenMask
) -> tuple[Callable, str]:
    """The factory of one camera's foreground model for ``sequence`` under ``foreground.method``
    (see the module docstring), and why it was chosen, in words: ``make_background`` (the
    plate's), ``make_segmenter`` or ``make_given`` (the given masks').

    Raises:
        ConfigError: ``method`` is unknown, or wants what the sequence lacks (a plate, given
            masks) or segmentation that is not installed.
    """
    method = check_choice("foreground.method", method, METHODS)
    has_masks, has_plate = sequence.has_given_masks, sequence.has_background
    if method == "masks" or (method == "auto" and has_masks):
        if not has_masks:
            raise ConfigError(
                f"foreground.method=masks, but {sequence.root} holds no masks/<camera>/ folder or "
                "masks/<camera>.mp4 video; add them, or set foreground.method=auto"
            )
        return make_given, f"the recording's masks ({sequence.root / 'masks'})" + (
            " (auto: the recording holds them)" if method == "auto" else ""
        )
    if method == "plate" or (method == "auto" and has_plate):
        if not has_plate:
            sequence.background(sequence.cameras[0])  # the sequence's own error: where the plate should be
        name = _describe(make_background)["target"].rsplit(".", 1)[-1]
        return make_background, f"background subtraction ({name}) on the empty-scene plate" + (
            " (auto: the sequence has one)" if method == "auto" else ""
        )
    if not segmentation.available():
        why = (
            "foreground.method=segmentation asks for person segmentation"
            if method == "segmentation"
            else f"{sequence.root} has no empty-scene plate and no masks/, so its foreground needs person segmentation"
        )
        raise ConfigError(
            f"{why}, which is not installed: {segmentation.INSTALL}; or record the empty scene "
            "(background/<camera>.mp4), set dataset.background=[first,last], or give masks/<camera>/"
        )
    return make_segmenter, "person segmentation (MediaPipe Pose)" + (
        " (auto: no empty-scene plate and no masks/)" if method == "auto" else ""
    )


def _describe(make_model) -> dict:
    """What determines a model factory's masks: its target and arguments."""
    if isinstance(make_model, functools.partial):
        return {
            **_describe(make_model.func),
            "args": list(make_model.args),
            "kwargs": dict(sorted(make_model.keywords.items())),
        }
    return {"target": f"{make_model.__module__}.{make_model.__qualname__}"}


def _model_class(make_model) -> Any:
    """The class a model factory (a class or a partial of one) builds: a background model,
    a person segmenter or :class:`GivenMask`, each with ``needs_plate``, ``reads`` and
    ``finds_landmarks``."""
    while isinstance(make_model, functools.partial):
        make_model = make_model.func
    return make_model


def cache_key(sequence, make_model) -> str:
    """16 hex digits identifying the masks of ``sequence`` under ``make_model``."""
    meta_file = Path(sequence.root) / "sequence.json"
    state = {
        "format": CACHE_FORMAT,
        "background": _describe(make_model),
        "root": str(Path(sequence.root).resolve()),
        "meta": sequence.meta,
        "cameras": [cam.to_dict() for cam in sequence.cameras],
        "meta_mtime_ns": meta_file.stat().st_mtime_ns if meta_file.is_file() else None,
    }
    digest = hashlib.sha256(json.dumps(state, sort_keys=True, default=str).encode())
    if _model_class(make_model).needs_plate:
        for cam in sequence.cameras:
            for frame in sequence.background(cam):
                digest.update(np.ascontiguousarray(frame).tobytes())
    return digest.hexdigest()[:16]


class MaskCache:
    """Packed masks and landmarks per frame in ``folder`` (one ``NNNNNN.npz`` per frame)."""

    def __init__(self, folder: Path, cameras):
        self.folder = Path(folder)
        self.cameras = list(cameras)
        self.hits = self.misses = 0
        self._writable = True

    def path(self, frame: int) -> Path:
        """The cache file of ``frame`` (0-based): ``NNNNNN.npz`` in the cache folder."""
        return self.folder / f"{frame:06d}.npz"

    def load(self, frame: int) -> tuple[list[ForegroundMask], list[np.ndarray | None]] | None:
        """The frame's masks and landmarks (None for a camera without), or None if absent or
        unreadable (then they are recomputed)."""
        path = self.path(frame)
        if not path.is_file():
            self.misses += 1
            return None
        try:
            with np.load(path) as data:
                masks, landmarks = [], []
                for cam in self.cameras:
                    packed = data[cam.name]
                    if packed.shape != (cam.height, (cam.width + 31) // 32):
                        raise ValueError(f"camera {cam.name} has packed shape {packed.shape}")
                    masks.append(ForegroundMask(unpack_rows(packed, cam.width), packed))
                    key = f"{cam.name}.landmarks"
                    landmarks.append(data[key] if key in data.files else None)
        except (OSError, KeyError, ValueError, zipfile.BadZipFile) as exc:
            log.warning("foreground cache %s unreadable (%s); recomputing", path, exc)
            self.misses += 1
            return None
        self.hits += 1
        return masks, landmarks

    def save(self, frame: int, masks: list[ForegroundMask], landmarks: list[np.ndarray | None]) -> None:
        """Write atomically; a folder that cannot be written turns the cache off with a warning."""
        if not self._writable:
            return
        arrays = {cam.name: m.packed for cam, m in zip(self.cameras, masks)}
        arrays.update(
            {f"{cam.name}.landmarks": points for cam, points in zip(self.cameras, landmarks) if points is not None}
        )
        try:
            with atomic_writer(self.path(frame), "wb") as f:
                np.savez(f, **arrays)  # type: ignore[arg-type]  # packed: masks from a frame
        except OSError as exc:
            log.warning("foreground cache %s not writable (%s); masks will not be cached", self.folder, exc)
            self._writable = False


class Foreground:
    """Foreground masks of a sequence, in the ideal pin-hole geometry of :attr:`cameras`.

    Args:
        sequence: the opened sequence.
        make_model: factory returning one camera's fresh model (a Hydra ``_partial_``): a
            background model (:mod:`mmocap.stages.background`, fit on the sequence's plate),
            a :class:`~mmocap.stages.segmentation.PersonSegmenter` or :class:`GivenMask`
            (see :func:`choose_method`).
        cache_dir: folder of the mask cache, None = no cache (see the module docstring).
        method: how ``make_model`` was chosen, in words (:func:`choose_method`), for reports.
    """

    def __init__(self, sequence, make_model: Callable, cache_dir=DEFAULT_CACHE_DIR, method: str = ""):
        self.sequence = sequence
        self.make_model = make_model
        self.method = method
        self._models: list | None = None
        self._crowded: set[str] = set()  # cameras already warned of a second person
        model_class = _model_class(make_model)
        self.reads_masks = model_class.reads == "masks"
        #: the method finds MediaPipe's 2-D landmarks with the masks (person segmentation)
        self.finds_landmarks = bool(model_class.finds_landmarks)
        self.cache = (
            None
            if cache_dir is None or self.reads_masks
            else MaskCache(Path(cache_dir) / cache_key(sequence, make_model), sequence.cameras)
        )

    @property
    def cameras(self):
        """The ideal pin-hole cameras the masks belong to."""
        return [cam.ideal() for cam in self.sequence.cameras]

    @property
    def models(self) -> list:
        """One model per camera, a background model fit on the plate (on first use)."""
        if self._models is None:
            self._models = []
            for cam in self.sequence.cameras:
                model = self.make_model()
                if model.needs_plate:
                    model.fit(self.sequence.background(cam), name=cam.name)
                self._models.append(model)
        return self._models

    def detect(self, frame: int, images: list[np.ndarray] | None = None) -> list[tuple[np.ndarray, np.ndarray | None]]:
        """Per camera, ``(mask, landmarks)`` in the images' own (distorted) geometry: an (H, W)
        bool mask and (33, 3) landmarks ``u, v`` px and visibility, or None."""
        if images is None:
            images = self.sequence.given_masks(frame) if self.reads_masks else self.sequence.images(frame)
        return [
            model.find_person(img, name=cam.name) for cam, model, img in zip(self.sequence.cameras, self.models, images)
        ]

    def detections(
        self, frame: int, images: list[np.ndarray] | None = None
    ) -> tuple[list[ForegroundMask], list[np.ndarray | None]]:
        """Per camera, the undistorted mask and the landmarks ((33, 3) ``u, v`` px in the
        ideal pin-hole camera and visibility in [0, 1], or None) of ``frame``; from the cache
        unless ``images`` (which replace the sequence's) are given."""
        use_cache = self.cache is not None and images is None
        cached = self.cache.load(frame) if use_cache else None  # type: ignore[union-attr]  # use_cache: a cache
        if cached is not None:
            masks, landmarks = cached
        else:
            found = self.detect(frame, images)
            masks = [ForegroundMask(cam.undistort_mask(mask)) for cam, (mask, _) in zip(self.sequence.cameras, found)]
            landmarks = [points for _, points in found]
            if use_cache:
                self.cache.save(frame, masks, landmarks)  # type: ignore[union-attr]  # use_cache: a cache
        for cam, mask in zip(self.sequence.cameras, masks):
            self._check_one_person(frame, cam.name, mask)
        return masks, [self._ideal(cam, p) for cam, p in zip(self.sequence.cameras, landmarks)]

    def _check_one_person(self, frame: int, name: str, mask: np.ndarray) -> None:
        """Warn, once per camera, when ``mask`` holds two or more person-sized regions."""
        if name in self._crowded:
            return
        count, _, stats, _ = cv2.connectedComponentsWithStats(np.asarray(mask, np.uint8), connectivity=8)
        areas = np.sort(stats[1:, cv2.CC_STAT_AREA])[::-1]
        if areas.size < 2 or areas[1] < max(SECOND_PERSON_RATIO * areas[0], PERSON_MIN_FRACTION * mask.size):
            return
        self._crowded.add(name)
        people = int(np.count_nonzero(areas >= max(SECOND_PERSON_RATIO * areas[0], PERSON_MIN_FRACTION * mask.size)))
        warnings.warn(
            f"camera {name}: the foreground of frame {frame} holds {people} separate person-sized regions "
            f"({', '.join(str(int(a)) for a in areas[:people])} px): mmocap tracks one person, and the others "
            "pull the model; keep one person in the masks, or set largest_only=true for the foreground "
            "method (background.largest_only, foreground.masks.largest_only)",
            MmocapWarning,
            stacklevel=2,
        )

    def masks(self, frame: int, images: list[np.ndarray] | None = None) -> list[ForegroundMask]:
        """Undistorted foreground per camera for ``frame`` (:meth:`detections`' masks)."""
        return self.detections(frame, images)[0]

    def landmarks(self, frame: int) -> list[np.ndarray | None]:
        """(33, 3) landmarks per camera of ``frame`` in the ideal pin-hole cameras, or None
        where the method finds none (:meth:`detections`' landmarks)."""
        return self.detections(frame)[1]

    @staticmethod
    def _ideal(camera, points: np.ndarray | None) -> np.ndarray | None:
        """(N, 3) ``u, v`` px through ``camera``'s lens and visibility -> the same points in
        the ideal pin-hole camera (the undistortion stage's geometry)."""
        if points is None or not np.any(camera.dist):
            return points
        return np.column_stack([camera.ideal_pixels(points[:, :2]), points[:, 2]]).astype(np.float32)


class ForegroundCoverage:
    """Finds cameras that cannot see the person: their foreground is empty, or covers
    nearly the whole image, frame after frame (``coverage`` in ``conf/config.yaml``).

    Coverage is the fraction of a mask's pixels that are foreground. A camera whose coverage
    stays below ``min_fraction`` (black, covered or unplugged; the person out of view) or
    above ``max_fraction`` (camera moved, light changed, wrong background frames) for
    ``frames`` frames in a row (or for every frame of a shorter run) is faulty. Then
    ``action`` decides: ``stop`` the run with an error naming the camera, or ``drop`` the
    camera from the following frames with a :class:`~mmocap.errors.MmocapWarning`.

    A camera whose mask is empty in a frame (person segmentation found nobody, or a given
    mask is blank) is left out of that frame only, and that frame does not count towards its
    streak: an empty mask would pull the model out of that camera's view, and a person missed
    for a few frames is no faulty camera. :attr:`skipped` records the frames per camera, and
    :meth:`warn_skipped` says so in one warning per camera at the end of the run.

    Args:
        action: ``stop`` or ``drop``.
        min_fraction, max_fraction: the usable coverage, fractions of the image in [0, 1].
        frames: consecutive faulty frames that make a camera faulty (>= 1).
    """

    ACTIONS = ("stop", "drop")

    def __init__(self, action: str = "stop", min_fraction: float = 0.001, max_fraction: float = 0.5, frames: int = 5):
        if action not in self.ACTIONS:
            raise ConfigError(f"coverage.action must be one of {', '.join(self.ACTIONS)}, got {action!r}")
        self.action = action
        self.min_fraction = check_number("coverage.min_fraction", min_fraction, 0.0, 1.0)
        self.max_fraction = check_number("coverage.max_fraction", max_fraction, self.min_fraction, 1.0, low_open=True)
        self.frames = check_number("coverage.frames", frames, 1, integer=True)
        self._streak: dict[str, int] = {}
        self.dropped: list[str] = []
        self.skipped: dict[str, list[int]] = {}

    def select(
        self, frame: int, cameras: list, masks: list[ForegroundMask], last_frame: int
    ) -> tuple[list, list[ForegroundMask]]:
        """The cameras (and their masks) to track ``frame`` with: those not dropped.

        ``last_frame`` is the run's last frame: a camera faulty on every frame of a run
        shorter than ``frames`` is faulty too. Raises DataError for a faulty camera under
        ``stop``, or when no camera is left."""
        kept_cameras, kept_masks = [], []
        for cam, mask in zip(cameras, masks):
            if cam.name in self.dropped:
                continue
            fraction = float(np.count_nonzero(mask)) / mask.size
            if fraction == 0:  # nobody found: left out of this frame only, not a faulty camera
                self.skipped.setdefault(cam.name, []).append(frame)
                continue
            low, high = fraction < self.min_fraction, fraction > self.max_fraction
            self._streak[cam.name] = self._streak.get(cam.name, 0) + 1 if low or high else 0
            streak = self._streak[cam.name]
            if streak >= self.frames or (frame == last_frame and streak == frame + 1):
                what = (
                    f"below coverage.min_fraction={self.min_fraction:g}: the camera sees no person "
                    "(black, covered or out-of-view images?)"
                    if low
                    else f"above coverage.max_fraction={self.max_fraction:g}: its background model does "
                    "not fit the scene (camera moved, light changed, wrong background frames?)"
                )
                message = (
                    f"camera {cam.name}: foreground covers {fraction:.2%} of the image, {what}, "
                    f"in frames {frame - streak + 1}-{frame}"
                )
                if self.action == "stop":
                    raise DataError(
                        f"{message}; check that camera's images, or set coverage.action=drop to track without it"
                    )
                warnings.warn(
                    f"{message}; dropped from the tracking from frame {frame} on (coverage.action=drop)",
                    MmocapWarning,
                    stacklevel=2,
                )
                self.dropped.append(cam.name)
                continue
            kept_cameras.append(cam)
            kept_masks.append(mask)
        if not kept_cameras:
            empty = [cam.name for cam in cameras if frame in self.skipped.get(cam.name, [])]
            raise DataError(
                f"frame {frame}: no camera left to track with (dropped: {', '.join(self.dropped) or 'none'}; "
                f"nobody in the foreground of: {', '.join(empty) or 'none'}); check the cameras' images "
                "and background frames, or track the frames where the person is in view (dataset.start, "
                "tracking.frames)"
            )
        return kept_cameras, kept_masks

    def warn_skipped(self, frames: int) -> None:
        """One :class:`~mmocap.errors.MmocapWarning` per camera left out of some of the run's
        ``frames`` frames for an empty mask (:attr:`skipped`)."""
        for name, skipped in self.skipped.items():
            warnings.warn(
                f"camera {name}: nobody in its foreground in {len(skipped)} of {frames} frames "
                f"({_ranges(skipped)}): left out of those frames (the person out of view, hidden, "
                "or missed by the segmentation)",
                MmocapWarning,
                stacklevel=2,
            )


def _ranges(frames: list[int]) -> str:
    """[3, 4, 5, 9] -> "3-5, 9"."""
    runs: list[list[int]] = []
    for frame in frames:
        if runs and frame == runs[-1][1] + 1:
            runs[-1][1] = frame
        else:
            runs.append([frame, frame])
    return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in runs)
