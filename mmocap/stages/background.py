"""Background models for the foreground stage: one per camera, fit on empty-scene frames.

A model has ``fit(frames, name=None)`` and ``apply(image, name=None) -> (H, W) bool``;
``name`` (the camera's) only goes into error messages. Images are (H, W) greyscale or
(H, W, channels) colour arrays of 8-bit values.
"""
from __future__ import annotations

import numbers

import cv2
import numpy as np

from mmocap.errors import ConfigError, DataError


def _as_channels(image: np.ndarray) -> np.ndarray:
    """(H, W) or (H, W, ch) image -> (H, W, ch) float32."""
    image = np.asarray(image)
    if image.ndim == 2:
        image = image[:, :, None]
    return image.astype(np.float32)


def _where(name: str | None) -> str:
    return f"camera {name}: " if name else ""


class GaussianBackground:
    """Per-pixel Gaussian background: mean and standard deviation of every channel.

    A pixel is foreground where ``max_channel |I - mean| / std > threshold``; the mask is
    then opened, closed and cleared of small connected components (8-connected).

    Args:
        threshold: normalised distance above which a pixel is foreground, > 0.
        min_sigma: floor of the per-pixel standard deviation in grey levels, > 0 (absorbs
            sensor noise that a few frames underestimate).
        open_px: diameter in pixels of the elliptical opening (removes specks); 0 = off.
        close_px: diameter in pixels of the elliptical closing (fills pinholes); 0 = off.
        min_area_px: connected components with fewer pixels are removed; 0 = off.
    """

    def __init__(self, threshold: float = 4.0, min_sigma: float = 3.0, open_px: int = 0,
                 close_px: int = 3, min_area_px: int = 50):
        for param, value in (("threshold", threshold), ("min_sigma", min_sigma)):
            real = isinstance(value, numbers.Real) and not isinstance(value, bool)
            if not (real and np.isfinite(value) and value > 0):
                raise ConfigError(f"background.{param} must be a finite number > 0, got {value!r}")
        sizes = (("open_px", open_px), ("close_px", close_px), ("min_area_px", min_area_px))
        for param, value in sizes:
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
                raise ConfigError(f"background.{param} must be an integer >= 0, got {value!r}")
        self.threshold = float(threshold)
        self.min_sigma = float(min_sigma)
        self.open_px = int(open_px)
        self.close_px = int(close_px)
        self.min_area_px = int(min_area_px)
        self.mean: np.ndarray | None = None
        self.std: np.ndarray | None = None
        self._shape: tuple | None = None

    def fit(self, frames, name: str | None = None) -> "GaussianBackground":
        """Estimate the model from background frames, all (H, W) or all (H, W, ch), at least 2.

        Stores ``mean`` and ``std`` (H, W, ch) float32; ``std`` is the sample standard
        deviation floored at ``min_sigma``.
        """
        frames = list(frames)
        if len(frames) < 2:
            raise DataError(f"{_where(name)}the background model needs at least 2 background frames, "
                            f"got {len(frames)}")
        shape = np.shape(frames[0])
        total = np.zeros(_as_channels(frames[0]).shape, np.float64)
        squares = np.zeros_like(total)
        for k, frame in enumerate(frames):
            if np.shape(frame) != shape:
                raise DataError(f"{_where(name)}background frame {k} has shape {np.shape(frame)}, "
                                f"frame 0 has {shape}")
            f = _as_channels(frame).astype(np.float64)
            total += f
            squares += f * f
        n = len(frames)
        mean = total / n
        var = np.maximum(squares - total * mean, 0.0) / (n - 1)
        self.mean = mean.astype(np.float32)
        self.std = np.maximum(np.sqrt(var), self.min_sigma).astype(np.float32)
        self._shape = shape
        return self

    def apply(self, image: np.ndarray, name: str | None = None) -> np.ndarray:
        """(H, W) or (H, W, ch) image like the fitted frames -> (H, W) bool foreground."""
        if self.mean is None:
            raise RuntimeError("GaussianBackground.apply called before fit")
        if np.shape(image) != self._shape:
            raise DataError(f"{_where(name)}image has shape {np.shape(image)} but the background "
                            f"model was fit on frames of shape {self._shape}")
        distance = (np.abs(_as_channels(image) - self.mean) / self.std).max(axis=2)
        mask = (distance > self.threshold).astype(np.uint8)
        if self.open_px:
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, _disc(self.open_px))
        if self.close_px:
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, _disc(self.close_px))
        if self.min_area_px:
            _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            big = stats[:, cv2.CC_STAT_AREA] >= self.min_area_px
            big[0] = False                                  # label 0 is the background
            return big[labels]
        return mask.astype(bool)


def _disc(size: int) -> np.ndarray:
    """Elliptical structuring element of diameter ``size`` pixels."""
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
