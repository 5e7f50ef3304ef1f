"""Stage "background": per-camera background models, fit on empty-scene frames.

A model has ``fit(frames, name=None)`` and ``apply(image, name=None) -> (H, W) bool``;
``name`` (the camera's) only goes into error messages. Images are (H, W) greyscale or
(H, W, channels) colour arrays of 8-bit values. Models:

- :class:`HorprasertBackground` (``background=horprasert``, the default): the statistical
  colour model of Horprasert, Harwood and Davis (1999), which tells shadows and highlights
  (the background darker or brighter) from foreground (the background replaced);
- :class:`GaussianBackground` (``background=gaussian``): per-pixel mean and spread;
- :class:`OpenCVBackground` (``background=mog2`` or ``background=knn``): OpenCV's Gaussian
  mixture (Zivkovic 2004) and k-nearest-neighbour (Zivkovic and van der Heijden 2006)
  subtractors, trained on the background frames and then applied without learning.

Every model ends with the same optional clean-up of the binary mask (:class:`Cleanup`):
opening, closing, removal of small components, keeping only the largest one.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import cv2
import numpy as np

from mmocap.errors import ConfigError, DataError
from mmocap.validate import check_flag, check_number

# Labels of HorprasertBackground.classify.
BACKGROUND, SHADOW, HIGHLIGHT, FOREGROUND = 0, 1, 2, 3


def _as_channels(image: np.ndarray) -> np.ndarray:
    """(H, W) or (H, W, ch) image -> (H, W, ch) float32."""
    image = np.asarray(image)
    if image.ndim == 2:
        image = image[:, :, None]
    return image.astype(np.float32)


def _where(name: str | None) -> str:
    return f"camera {name}: " if name else ""


def _disc(size: int) -> np.ndarray:
    """Elliptical structuring element of diameter ``size`` pixels."""
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))


class Cleanup:
    """Clean-up of a binary mask, in this order: opening, closing, components.

    Args:
        open_px: diameter in pixels of the elliptical opening (removes specks); 0 = off.
        close_px: diameter in pixels of the elliptical closing (fills pinholes); 0 = off.
        min_area_px: 8-connected components with fewer pixels are removed; 0 = off.
        largest_only: keep only the largest component (one person in the scene).
    """

    def __init__(self, open_px: int = 0, close_px: int = 3, min_area_px: int = 50, largest_only: bool = False):
        self.open_px = check_number("background.open_px", open_px, 0, integer=True)
        self.close_px = check_number("background.close_px", close_px, 0, integer=True)
        self.min_area_px = check_number("background.min_area_px", min_area_px, 0, integer=True)
        self.largest_only = check_flag("background.largest_only", largest_only)

    def __call__(self, mask: np.ndarray) -> np.ndarray:
        """(H, W) bool or 0/1 uint8 -> (H, W) bool."""
        mask = np.asarray(mask, dtype=np.uint8)
        if self.open_px:
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, _disc(self.open_px))
        if self.close_px:
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, _disc(self.close_px))
        if not (self.min_area_px or self.largest_only):
            return mask.astype(bool)
        count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        area = stats[:, cv2.CC_STAT_AREA]
        keep = area >= self.min_area_px
        keep[0] = False  # label 0 is the background
        if self.largest_only and count > 1:
            keep &= np.arange(count) == 1 + np.argmax(area[1:])
        return keep[labels]


class BackgroundModel(ABC):
    """Shared frame checks and clean-up of the background models.

    Subclasses set ``min_frames`` and implement ``_fit(stack)`` and ``_detect(image)``.
    The keyword arguments are those of :class:`Cleanup`.
    """

    min_frames = 2
    #: fit on the empty scene's frames (:mod:`mmocap.stages.foreground` reads them for it)
    needs_plate = True
    #: applied to the camera's images (not to given masks)
    reads = "images"
    #: finds no 2-D landmarks (person segmentation does)
    finds_landmarks = False

    def __init__(self, open_px: int = 0, close_px: int = 3, min_area_px: int = 50, largest_only: bool = False):
        self.cleanup = Cleanup(open_px, close_px, min_area_px, largest_only)
        self._shape: tuple | None = None

    def fit(self, frames, name: str | None = None) -> BackgroundModel:
        """Estimate the model from background frames, all (H, W) or all (H, W, ch)."""
        frames = list(frames)
        if len(frames) < self.min_frames:
            raise DataError(
                f"{_where(name)}the {type(self).__name__} model needs at least "
                f"{self.min_frames} background frames, got {len(frames)}"
            )
        shape = np.shape(frames[0])
        if len(shape) not in (2, 3):
            raise DataError(f"{_where(name)}background frame 0 has shape {shape}, expected (H, W) or (H, W, channels)")
        for k, frame in enumerate(frames):
            if np.shape(frame) != shape:
                raise DataError(f"{_where(name)}background frame {k} has shape {np.shape(frame)}, frame 0 has {shape}")
        self._fit([np.asarray(f) for f in frames])
        self._shape = shape
        return self

    def apply(self, image: np.ndarray, name: str | None = None) -> np.ndarray:
        """(H, W) or (H, W, ch) image like the fitted frames -> (H, W) bool foreground."""
        self._check_image(image, name)
        return self.cleanup(self._detect(np.asarray(image)))

    def find_person(self, image: np.ndarray, name: str | None = None) -> tuple[np.ndarray, None]:
        """:meth:`apply`, as every foreground model answers: ((H, W) bool mask, no landmarks)."""
        return self.apply(image, name), None

    def _check_image(self, image: np.ndarray, name: str | None) -> None:
        if self._shape is None:
            raise RuntimeError(f"{type(self).__name__}.apply called before fit")
        if np.shape(image) != self._shape:
            raise DataError(
                f"{_where(name)}image has shape {np.shape(image)} but the background "
                f"model was fit on frames of shape {self._shape}"
            )

    @abstractmethod
    def _fit(self, frames: list[np.ndarray]) -> None:
        """Learn from at least ``min_frames`` frames of one shape."""

    @abstractmethod
    def _detect(self, image: np.ndarray) -> np.ndarray:
        """(H, W) bool or 0/1 uint8 raw foreground of one image, before the clean-up."""


def _mean_std(frames: list[np.ndarray], min_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel mean and sample standard deviation floored at ``min_sigma``, (H, W, ch) float32."""
    total = np.zeros(_as_channels(frames[0]).shape, np.float64)
    squares = np.zeros_like(total)
    for frame in frames:
        f = _as_channels(frame).astype(np.float64)
        total += f
        squares += f * f
    n = len(frames)
    mean = total / n
    var = np.maximum(squares - total * mean, 0.0) / (n - 1)
    return mean.astype(np.float32), np.maximum(np.sqrt(var), min_sigma).astype(np.float32)


class GaussianBackground(BackgroundModel):
    """Per-pixel Gaussian background: mean and standard deviation of every channel.

    A pixel is foreground where ``max_channel |I - mean| / std > threshold``.

    Args:
        threshold: normalised distance above which a pixel is foreground, > 0.
        min_sigma: floor of the per-pixel standard deviation in grey levels, > 0 (absorbs
            sensor noise that a few frames underestimate).
        open_px, close_px, min_area_px, largest_only: the :class:`Cleanup`.
    """

    def __init__(
        self,
        threshold: float = 4.0,
        min_sigma: float = 3.0,
        open_px: int = 0,
        close_px: int = 3,
        min_area_px: int = 50,
        largest_only: bool = False,
    ):
        self.threshold = check_number("background.threshold", threshold, 0, low_open=True)
        self.min_sigma = check_number("background.min_sigma", min_sigma, 0, low_open=True)
        super().__init__(open_px, close_px, min_area_px, largest_only)
        self.mean: np.ndarray | None = None
        self.std: np.ndarray | None = None

    def _fit(self, frames: list[np.ndarray]) -> None:
        """Stores ``mean`` and ``std``, (H, W, ch) float32."""
        self.mean, self.std = _mean_std(frames, self.min_sigma)

    def _detect(self, image: np.ndarray) -> np.ndarray:
        distance = (np.abs(_as_channels(image) - self.mean) / self.std).max(axis=2)
        return distance > self.threshold


class HorprasertBackground(BackgroundModel):
    """Horprasert et al. (1999): brightness and chromaticity distortion per pixel.

    Each pixel's background is its mean colour ``E`` and spread ``s`` per channel over the
    background frames. An observed colour ``I`` is compared with it by the brightness
    distortion ``alpha`` (the scale of ``E`` nearest to ``I``, 1 = as bright as the
    background) and the chromaticity distortion ``CD`` (the distance left, in units of ``s``)::

        alpha = sum(I E / s^2) / sum(E^2 / s^2),   CD^2 = sum((I - alpha E)^2 / s^2)

    Both are normalised by their per-pixel RMS over the background frames,
    ``alpha_n = (alpha - 1) / rms(alpha - 1)`` and ``CD_n = CD / rms(CD)``, and the
    thresholds come from the background frames themselves: ``tau_cd`` is the
    ``detection_rate`` quantile of ``CD_n`` over all their pixels, and ``alpha_n`` must lie
    between its ``(1 - detection_rate) / 2`` and ``(1 + detection_rate) / 2`` quantiles.
    A pixel is then foreground if ``CD_n > tau_cd`` or ``alpha`` is outside
    ``[shadow_min_alpha, highlight_max_alpha]``; else background if ``alpha_n`` is between
    its thresholds, shadow if below them, highlight if above. Shadows and highlights are
    background in the mask.

    Estimation from few frames (HumanEva-like sets have about 10): ``s^2``, ``rms(alpha - 1)``
    and ``rms(CD)`` are averaged over a Gaussian of ``RMS_SMOOTHING_PX`` around each pixel,
    and each background frame is compared with the mean of the other frames. Without this,
    a frame's distortions, normalised by statistics of the same few frames, stay small
    (``CD_n`` cannot exceed sqrt(frames)) and give thresholds that new frames exceed often.

    One channel: there ``alpha = I / E`` fits the single value exactly and ``CD`` is always 0,
    so chromaticity is undefined. On greyscale images ``CD`` is measured over the values of
    the ``grey_window_px`` square around the pixel instead of the colour channels, after
    fitting the background's values there with a brightness that may vary linearly across
    the window, ``(a + b dx + c dy) E`` (weighted least squares, ``dx, dy`` the offsets from
    the pixel): a soft shadow, penumbra included, scales the local texture of the
    background, which the fit absorbs, while a person replaces it, which ``CD`` measures.
    ``alpha`` stays the pixel's own, and a pixel as bright as its background (``alpha_n``
    between the thresholds) is background whatever the window's ``CD``, so the mask does not
    grow by half a window around the person. A hard shadow edge across strong texture can
    still show as a thin line. ``grey_window_px=1`` leaves brightness alone to decide.
    Colour images use one pixel's channels, as the paper.

    Compressed video (H.264 and the like): an empty scene encodes almost unchanged from
    frame to frame, so the background frames' spread and RMS leave out the codec's error,
    while the video of the person was encoded apart, with its own error: heavy-tailed,
    largest at edges and texture. Measured on a synthetic sequence at ``crf`` 23, 29 % of
    a camera's background pixels exceed ``tau_cd`` (0.1 % lossless). So each image's noise is
    also measured: ``n_t``, the ``NOISE_QUANTILE`` (0.9: the codec's error is in the tail) of
    ``CD s``, ``CD`` times the pixel's spread, in grey levels, over each tile ``t`` of a
    ``TILES`` x ``TILES`` grid, against the largest ``n0_t`` of the background frames (each
    against the mean of the others). The ``TILE_QUANTILE`` (0.75) of the ratios ``n_t /
    n0_t`` over the tiles, ``r``, ignores a person in fewer than a quarter of the tiles;
    beyond ``m`` = ``NOISE_MARGIN``, the codec's noise is ``sqrt(r^2 - m^2)`` times the
    median ``n0_t``, and ``CD s`` must also exceed it ``codec_threshold`` times for a pixel
    to be foreground on its chromaticity. An image about as noisy as the background frames
    (lossless video, a camera's own images) is classified as before.

    Departures from the paper: the bounds on ``alpha`` are in raw brightness (the paper's
    ``tau_alpha_lo`` is on the normalised one) and there is also an upper bound, so a white
    shirt before a grey wall is foreground, not a highlight; ``s`` is floored at
    ``min_sigma`` and the RMS at small constants, so flat or saturated regions do not divide
    by zero.

    Args:
        detection_rate: fraction of the background frames' pixels classified as background,
            in (0, 1); sets the thresholds.
        min_sigma: floor of the per-pixel spread, grey levels, > 0.
        shadow_min_alpha: darkest shadow, as a fraction of the background's brightness, in (0, 1).
        highlight_max_alpha: brightest highlight, as a multiple of it, > 1.
        grey_window_px: side of the neighbourhood used as the vector on one-channel
            images, odd, >= 1.
        codec_threshold: multiple of an image's noise beyond the background frames' (the
            codec's, on compressed video) that a foreground pixel's ``CD s`` exceeds, > 0.
        open_px, close_px, min_area_px, largest_only: the :class:`Cleanup`.
    """

    min_frames = 3
    MIN_ALPHA_RMS = 1e-3  # floor of rms(alpha - 1): a fraction of the brightness
    MIN_CD_RMS = 0.1  # floor of rms(CD): in units of the spread s
    RMS_SMOOTHING_PX = 2.0  # sigma of the averaging of s^2 and of the RMS, pixels
    # an image's noise up to this multiple of the background frames' is not the codec's: a
    # person covering a fifth of the image raises the median by about as much
    NOISE_MARGIN = 1.1
    NOISE_QUANTILE = 0.9
    # floor of n0_t, grey levels: the rounding of 8-bit values (a plate whose frames the codec
    # copies bit for bit differs by nothing else)
    MIN_NOISE = 1 / np.sqrt(12)
    TILES = 8  # the image's noise is measured per tile of a TILES x TILES grid
    TILE_QUANTILE = 0.75  # of the tiles' ratios: a person in fewer than a quarter of the tiles does not count

    def __init__(
        self,
        detection_rate: float = 0.999,
        min_sigma: float = 2.0,
        shadow_min_alpha: float = 0.55,
        highlight_max_alpha: float = 1.5,
        grey_window_px: int = 5,
        codec_threshold: float = 10.0,
        open_px: int = 0,
        close_px: int = 3,
        min_area_px: int = 50,
        largest_only: bool = False,
    ):
        self.detection_rate = check_number(
            "background.detection_rate", detection_rate, 0, 1, low_open=True, high_open=True
        )
        self.min_sigma = check_number("background.min_sigma", min_sigma, 0, low_open=True)
        self.shadow_min_alpha = check_number(
            "background.shadow_min_alpha", shadow_min_alpha, 0, 1, low_open=True, high_open=True
        )
        self.highlight_max_alpha = check_number("background.highlight_max_alpha", highlight_max_alpha, 0, low_open=True)
        if self.highlight_max_alpha <= 1:
            raise ConfigError(f"background.highlight_max_alpha must be > 1, got {highlight_max_alpha!r}")
        self.grey_window_px = check_number("background.grey_window_px", grey_window_px, 1, integer=True)
        if self.grey_window_px % 2 == 0:
            raise ConfigError(f"background.grey_window_px must be odd, got {grey_window_px!r}")
        self.codec_threshold = check_number("background.codec_threshold", codec_threshold, 0, low_open=True)
        super().__init__(open_px, close_px, min_area_px, largest_only)
        self.mean: np.ndarray | None = None  # (H, W, ch) E, grey levels
        self.std: np.ndarray | None = None  # (H, W, ch) s, grey levels
        self.alpha_rms: np.ndarray | None = None  # (H, W) rms(alpha - 1)
        self.cd_rms: np.ndarray | None = None  # (H, W) rms(CD)
        self.tau_cd: float | None = None
        self.tau_alpha_low: float | None = None
        self.tau_alpha_high: float | None = None
        self.noise: np.ndarray | None = None  # (TILES^2,) n_0 per tile: the background frames' largest, grey levels

    def _smooth(self, x: np.ndarray) -> np.ndarray:
        """(H, W) per-pixel mean squares -> their mean over about RMS_SMOOTHING_PX around."""
        return cv2.GaussianBlur(x, (0, 0), self.RMS_SMOOTHING_PX, borderType=cv2.BORDER_REFLECT)

    def _window(self) -> int:
        return self.grey_window_px if self.mean.shape[2] == 1 else 1  # type: ignore[union-attr]  # after fit

    def _window_sums(self, x: np.ndarray, kernels) -> np.ndarray:
        """(H, W) -> (H, W, K): per pixel, the sum over its window of ``x`` times each of the
        K (w, w) ``kernels`` (functions of the offset from the pixel)."""
        x = x.astype(np.float64)
        return np.stack([cv2.filter2D(x, -1, k, borderType=cv2.BORDER_REFLECT) for k in kernels], axis=-1)

    def _prepare(self) -> None:
        """Per-pixel terms of alpha and CD that depend on the background only."""
        self._inv_var = 1.0 / (self.std * self.std)  # type: ignore[operator]  # after fit
        self._e_over_var = self.mean * self._inv_var
        e2 = (self.mean * self._e_over_var).sum(axis=2)
        self._e2 = np.maximum(e2, 1e-6)
        self._spread = np.sqrt((self.std * self.std).mean(axis=2))  # type: ignore[operator]  # after fit
        w = self._window()
        if w > 1:
            # brightness plane 1, dx, dy over the window: its weighted normal matrix, inverted
            r = w // 2
            dy, dx = np.mgrid[-r : r + 1, -r : r + 1].astype(np.float64)
            self._plane = (np.ones((w, w)), dx, dy)
            pairs = [(k, l) for k in range(3) for l in range(k, 3)]
            sums = self._window_sums(self._e2, [self._plane[k] * self._plane[l] for k, l in pairs])
            normal = np.empty(sums.shape[:2] + (3, 3))
            for n, (k, l) in enumerate(pairs):
                normal[..., k, l] = normal[..., l, k] = sums[..., n]
            normal += 1e-9 * sums[..., :1, None] * np.eye(3)
            self._plane_inverse = np.linalg.inv(normal).astype(np.float32)

    def distortions(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Brightness distortion ``alpha`` of each pixel and chromaticity distortion ``CD``
        of its vector (the channels, or the window on one channel), (H, W) float32 each."""
        f = _as_channels(image)
        ie = (f * self._e_over_var).sum(axis=2)
        i2 = (f * f * self._inv_var).sum(axis=2)
        alpha = ie / self._e2
        if self._window() == 1:
            cd2 = i2 - alpha * ie  # sum((I - alpha E)^2 / s^2)
        else:
            # sum((I - (a + b dx + c dy) E)^2 / s^2) at the weighted least-squares a, b, c
            v = self._window_sums(ie, self._plane)
            fit = np.einsum("...ij,...j->...i", self._plane_inverse, v)
            cd2 = self._window_sums(i2, self._plane[:1])[..., 0] - np.einsum("...i,...i->...", fit, v)
        return alpha, np.sqrt(np.maximum(cd2, 0.0)).astype(np.float32)

    def _fit(self, frames: list[np.ndarray]) -> None:
        self.mean, std = _mean_std(frames, 0.0)
        var = self._smooth(std * std).reshape(std.shape)
        self.std = np.maximum(np.sqrt(var), self.min_sigma)
        self._prepare()
        n = len(frames)
        # Each frame against the mean of the others: I_k - E_{-k} = n / (n - 1) (I_k - E).
        alphas, cds = zip(
            *(self.distortions(self.mean + (_as_channels(f) - self.mean) * (n / (n - 1))) for f in frames)
        )
        alphas, cds = np.stack(alphas), np.stack(cds)
        self.alpha_rms = np.maximum(np.sqrt(self._smooth(np.mean((alphas - 1) ** 2, axis=0))), self.MIN_ALPHA_RMS)
        self.cd_rms = np.maximum(np.sqrt(self._smooth(np.mean(cds * cds, axis=0))), self.MIN_CD_RMS)
        r = self.detection_rate
        self.tau_alpha_low, self.tau_alpha_high = (
            float(q) for q in np.quantile((alphas - 1) / self.alpha_rms, [(1 - r) / 2, (1 + r) / 2])
        )
        self.tau_cd = float(np.quantile(cds / self.cd_rms, r))
        self.noise = np.maximum(np.max([self.image_noise(cd) for cd in cds], axis=0), self.MIN_NOISE)

    def image_noise(self, cd: np.ndarray) -> np.ndarray:
        """Noise of one image per tile, grey levels: the ``NOISE_QUANTILE`` of ``CD s`` over
        each of ``TILES`` x ``TILES`` tiles (``cd``: (H, W), in units of the spread; the last
        rows and columns that do not fill a tile are left out); (TILES^2,)."""
        values = cd * self._spread
        h, w = (n - n % self.TILES for n in values.shape)
        tiles = values[:h, :w].reshape(self.TILES, h // self.TILES, self.TILES, w // self.TILES).swapaxes(1, 2)
        return np.quantile(tiles.reshape(self.TILES * self.TILES, -1), self.NOISE_QUANTILE, axis=1)

    def codec_noise(self, cd: np.ndarray) -> float:
        """The codec's noise in an image, grey levels (0 if none): from the median over the
        tiles of the image's noise over the background frames', ``r``, beyond ``NOISE_MARGIN``:
        ``sqrt(r^2 - m^2)`` times the background frames' median noise."""
        ratio = float(np.quantile(self.image_noise(cd) / self.noise, self.TILE_QUANTILE))
        return float(np.sqrt(max(ratio**2 - self.NOISE_MARGIN**2, 0.0)) * np.median(self.noise))  # type: ignore[arg-type]

    def classify(self, image: np.ndarray, name: str | None = None) -> np.ndarray:
        """(H, W) uint8 labels: BACKGROUND, SHADOW, HIGHLIGHT or FOREGROUND (module constants)."""
        self._check_image(image, name)
        alpha, cd = self.distortions(np.asarray(image))
        alpha_n = (alpha - 1) / self.alpha_rms
        labels = np.full(alpha.shape, BACKGROUND, np.uint8)
        labels[alpha_n < self.tau_alpha_low] = SHADOW
        labels[alpha_n > self.tau_alpha_high] = HIGHLIGHT
        codec_noise = self.codec_noise(cd)
        chromatic = cd / self.cd_rms > self.tau_cd
        if codec_noise > 0:
            chromatic &= cd * self._spread > self.codec_threshold * codec_noise
        foreground = chromatic | (alpha < self.shadow_min_alpha) | (alpha > self.highlight_max_alpha)
        if self._window() > 1:
            # CD describes the neighbourhood: a pixel as bright as its background stays background
            foreground &= labels != BACKGROUND
        labels[foreground] = FOREGROUND
        return labels

    def _detect(self, image: np.ndarray) -> np.ndarray:
        return self.classify(image) == FOREGROUND


class OpenCVBackground(BackgroundModel):
    """OpenCV's MOG2 or KNN subtractor, trained on the background frames, applied frozen.

    Pixels the subtractor calls shadow are background in the mask.

    Args:
        method: ``"mog2"`` or ``"knn"``.
        threshold: MOG2's ``varThreshold`` (squared Mahalanobis distance) or KNN's
            ``dist2Threshold`` (squared distance in grey levels), > 0.
        detect_shadows: let the subtractor mark shadows (which then count as background).
        open_px, close_px, min_area_px, largest_only: the :class:`Cleanup`.
    """

    METHODS = ("mog2", "knn")

    def __init__(
        self,
        method: str = "mog2",
        threshold: float = 16.0,
        detect_shadows: bool = True,
        open_px: int = 0,
        close_px: int = 3,
        min_area_px: int = 50,
        largest_only: bool = False,
    ):
        if method not in self.METHODS:
            raise ConfigError(f"background.method must be one of {', '.join(self.METHODS)}, got {method!r}")
        detect_shadows = check_flag("background.detect_shadows", detect_shadows)
        self.method = method
        self.threshold = check_number("background.threshold", threshold, 0, low_open=True)
        self.detect_shadows = detect_shadows
        super().__init__(open_px, close_px, min_area_px, largest_only)
        self.subtractor: cv2.BackgroundSubtractor = None  # type: ignore[assignment]  # set by fit

    def _fit(self, frames: list[np.ndarray]) -> None:
        n = len(frames)
        if self.method == "mog2":
            self.subtractor = cv2.createBackgroundSubtractorMOG2(n, self.threshold, self.detect_shadows)
        else:
            self.subtractor = cv2.createBackgroundSubtractorKNN(n, self.threshold, self.detect_shadows)
        for frame in frames:
            self.subtractor.apply(frame, learningRate=-1)  # automatic rate 1 / frames seen
        self.subtractor.apply(frames[-1], learningRate=self._frozen_rate)

    @property
    def _frozen_rate(self) -> float:
        """Learning rate that leaves the model as it is. OpenCV's KNN turns a rate of 0 into
        an update period of log(0.7) / log(1) and keeps learning; 1e-9 means one update in
        about 10^9 frames. Its first call after training still settles the model, hence the
        extra background frame at the end of ``_fit``."""
        return 0.0 if self.method == "mog2" else 1e-9

    def _detect(self, image: np.ndarray) -> np.ndarray:
        return self.subtractor.apply(image, learningRate=self._frozen_rate) == 255
