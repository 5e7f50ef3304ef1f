"""Stage "foreground": background subtraction, undistortion, masks for the evaluators, cache.

Per frame and camera, the camera's background model (:mod:`mmocap.stages.background`, fit on
the sequence's background frames) gives a mask in the image's own, distorted geometry; the
undistortion stage then remaps it once with the camera's maps, computed once per camera by
``cv2.initUndistortRectifyMap`` (:meth:`mmocap.camera.Camera.undistort_mask`). From there on
the cameras are ideal pin-holes, ``camera.ideal()``: the Cano paper's approach (Sec. 3.2),
which undistorts the foreground once per frame and never the model's vertices.

The masks are :class:`ForegroundMask` arrays: (H, W) bool that also carry their row-packed
bits (the layout the OpenCL evaluator uploads) and ``|F|``.

Cache: one ``.npz`` per frame holding every camera's packed bits, in
``<cache_dir>/<key>/NNNNNN.npz``, ``key`` being a digest of the background model's
configuration and of the sequence: its folder, metadata, calibrations, the pixels of its
background frames and, where there is one, the modification time of its ``sequence.json``
(which a re-rendered sequence rewrites). A changed configuration or sequence thus reads and
writes another folder; files are written to a temporary name and renamed, so an interrupted
run never leaves a partial one. The default ``cache_dir`` is ``outputs/cache/foreground``
(relative to the working directory, like the runs), which keeps datasets read-only.
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

import numpy as np

from mmocap.bitmask import ForegroundMask, unpack_rows
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.io import atomic_writer
from mmocap.validate import check_number

log = logging.getLogger(__name__)
CACHE_FORMAT = 1  # bump when the masks of a given configuration change meaning
DEFAULT_CACHE_DIR = Path("outputs/cache/foreground")


def _describe(make_background) -> dict:
    """What determines a background factory's masks: its target and arguments."""
    if isinstance(make_background, functools.partial):
        return {
            **_describe(make_background.func),
            "args": list(make_background.args),
            "kwargs": dict(sorted(make_background.keywords.items())),
        }
    return {"target": f"{make_background.__module__}.{make_background.__qualname__}"}


def cache_key(sequence, make_background) -> str:
    """16 hex digits identifying the masks of ``sequence`` under ``make_background``."""
    meta_file = Path(sequence.root) / "sequence.json"
    state = {
        "format": CACHE_FORMAT,
        "background": _describe(make_background),
        "root": str(Path(sequence.root).resolve()),
        "meta": sequence.meta,
        "cameras": [cam.to_dict() for cam in sequence.cameras],
        "meta_mtime_ns": meta_file.stat().st_mtime_ns if meta_file.is_file() else None,
    }
    digest = hashlib.sha256(json.dumps(state, sort_keys=True, default=str).encode())
    for cam in sequence.cameras:
        for frame in sequence.background(cam):
            digest.update(np.ascontiguousarray(frame).tobytes())
    return digest.hexdigest()[:16]


class MaskCache:
    """Packed masks per frame in ``folder`` (one ``NNNNNN.npz`` per frame)."""

    def __init__(self, folder: Path, cameras):
        self.folder = Path(folder)
        self.cameras = list(cameras)
        self.hits = self.misses = 0
        self._writable = True

    def path(self, frame: int) -> Path:
        """The cache file of ``frame`` (0-based): ``NNNNNN.npz`` in the cache folder."""
        return self.folder / f"{frame:06d}.npz"

    def load(self, frame: int) -> list[ForegroundMask] | None:
        """The frame's masks, or None if absent or unreadable (then they are recomputed)."""
        path = self.path(frame)
        if not path.is_file():
            self.misses += 1
            return None
        try:
            with np.load(path) as data:
                masks = []
                for cam in self.cameras:
                    packed = data[cam.name]
                    if packed.shape != (cam.height, (cam.width + 31) // 32):
                        raise ValueError(f"camera {cam.name} has packed shape {packed.shape}")
                    masks.append(ForegroundMask(unpack_rows(packed, cam.width), packed))
        except (OSError, KeyError, ValueError, zipfile.BadZipFile) as exc:
            log.warning("foreground cache %s unreadable (%s); recomputing", path, exc)
            self.misses += 1
            return None
        self.hits += 1
        return masks

    def save(self, frame: int, masks: list[ForegroundMask]) -> None:
        """Write atomically; a folder that cannot be written turns the cache off with a warning."""
        if not self._writable:
            return
        try:
            with atomic_writer(self.path(frame), "wb") as f:
                np.savez(f, **{cam.name: m.packed for cam, m in zip(self.cameras, masks)})  # type: ignore[arg-type]  # packed: masks from a frame
        except OSError as exc:
            log.warning("foreground cache %s not writable (%s); masks will not be cached", self.folder, exc)
            self._writable = False


class Foreground:
    """Foreground masks of a sequence, in the ideal pin-hole geometry of :attr:`cameras`.

    Args:
        sequence: the opened sequence.
        make_background: factory returning a fresh background model with ``fit(frames)``
            and ``apply(image, name=...) -> (H, W) bool`` (a Hydra ``_partial_``).
        cache_dir: folder of the mask cache, None = no cache (see the module docstring).
    """

    def __init__(self, sequence, make_background: Callable, cache_dir=DEFAULT_CACHE_DIR):
        self.sequence = sequence
        self.make_background = make_background
        self._models: list | None = None
        self.cache = (
            None
            if cache_dir is None
            else MaskCache(Path(cache_dir) / cache_key(sequence, make_background), sequence.cameras)
        )

    @property
    def cameras(self):
        """The ideal pin-hole cameras the masks belong to."""
        return [cam.ideal() for cam in self.sequence.cameras]

    @property
    def models(self) -> list:
        """One fitted background model per camera (fit on first use)."""
        if self._models is None:
            self._models = [
                self.make_background().fit(self.sequence.background(cam), name=cam.name)
                for cam in self.sequence.cameras
            ]
        return self._models

    def detect(self, frame: int, images: list[np.ndarray] | None = None) -> list[np.ndarray]:
        """(H, W) bool foreground per camera in the images' own (distorted) geometry."""
        images = self.sequence.images(frame) if images is None else images
        return [model.apply(img, name=cam.name) for cam, model, img in zip(self.sequence.cameras, self.models, images)]

    def masks(self, frame: int, images: list[np.ndarray] | None = None) -> list[ForegroundMask]:
        """Undistorted foreground per camera for ``frame``; from the cache unless ``images``
        (which replace the sequence's) are given."""
        use_cache = self.cache is not None and images is None
        if use_cache:
            cached = self.cache.load(frame)  # type: ignore[union-attr]  # use_cache: a cache
            if cached is not None:
                return cached
        masks = [
            ForegroundMask(cam.undistort_mask(mask))
            for cam, mask in zip(self.sequence.cameras, self.detect(frame, images))
        ]
        if use_cache:
            self.cache.save(frame, masks)  # type: ignore[union-attr]  # use_cache: a cache
        return masks


class ForegroundCoverage:
    """Finds cameras that cannot see the person: their foreground is empty, or covers
    nearly the whole image, frame after frame (``coverage`` in ``conf/config.yaml``).

    Coverage is the fraction of a mask's pixels that are foreground. A camera whose coverage
    stays below ``min_fraction`` (black, covered or unplugged; the person out of view) or
    above ``max_fraction`` (camera moved, light changed, wrong background frames) for
    ``frames`` frames in a row (or for every frame of a shorter run) is faulty. Then
    ``action`` decides: ``stop`` the run with an error naming the camera, or ``drop`` the
    camera from the following frames with a :class:`~mmocap.errors.MmocapWarning`.

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
            raise DataError(
                f"frame {frame}: no camera left to track with (dropped: "
                f"{', '.join(self.dropped)}); check the cameras' images and background frames"
            )
        return kept_cameras, kept_masks
