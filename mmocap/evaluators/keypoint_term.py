"""The keypoint term of the hybrid fitness: silhouettes and 2-D keypoints in one objective.

``fitness = silhouette + weight * keypoint_term`` (:class:`KeypointTerm`). The keypoint term
of a candidate is the confidence-weighted mean, over the cameras ``c`` and the keypoints
``k`` seen there, of a robust loss of the reprojection distance::

    r_ck = |pi_c(point_k) - u_ck| / (scale * h_c)
    keypoint_term = sum_ck w_ck rho(r_ck) / sum_ck w_ck

with ``u_ck`` the detected pixel (ideal, undistorted camera), ``w_ck`` its confidence in
[0, 1], ``h_c`` the person's height in camera ``c``'s image (px; the foreground mask's
bounding box, :func:`person_height_px`), so that the term does not depend on the image's
size or the person's distance, and ``scale`` the distance, as a share of that height,
where the loss turns robust:

- ``geman_mcclure``: ``rho(r) = r^2 / (1 + r^2)``, bounded by 1: a swapped or misplaced
  joint costs at most its confidence's share, and the term lies in [0, 1];
- ``huber``: ``rho(r) = r^2 / 2`` up to ``r = 1``, ``r - 1/2`` beyond: linear, unbounded.

A point behind camera ``c`` (depth at most ``NEAR_MM``) counts as ``r = 1 / scale`` (one
person height away). Without any confident keypoint the term is 0.

The projections ``pi_c`` follow the silhouette rule's float32 arithmetic
(:func:`mmocap.evaluators.silhouette.keypoint_pixels`), so that every backend gives the same bits for them; the loss is
computed from them in float64 on the host, the same code for every backend.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mmocap.errors import ConfigError, DataError
from mmocap.validate import check_number

LOSSES = ("geman_mcclure", "huber")
#: the robust loss and its scale (a share of the person's image height) unless told otherwise
LOSS = "geman_mcclure"
SCALE = 0.05


@dataclass(frozen=True)
class KeypointTerm:
    """How much the keypoints count and how robustly (config ``keypoints.weight``, ``.loss``,
    ``.scale``).

    Attributes:
        weight: lambda, the term's weight beside the silhouette fitness (0 = silhouettes only).
        loss: ``geman_mcclure`` or ``huber`` (see the module docstring).
        scale: the robust loss's scale, as a share of the person's image height.
    """

    weight: float
    loss: str = LOSS
    scale: float = SCALE

    def __post_init__(self):
        object.__setattr__(self, "weight", check_number("keypoints.weight", self.weight, 0.0, 1e6))
        object.__setattr__(self, "scale", check_number("keypoints.scale", self.scale, 1e-6, 10.0))
        if self.loss not in LOSSES:
            raise ConfigError(f"keypoints.loss must be one of {', '.join(LOSSES)}, got {self.loss!r}")

    def rho(self, r: np.ndarray) -> np.ndarray:
        """The robust loss of normalised distances ``r`` (any shape, >= 0)."""
        if self.loss == "huber":
            return np.where(r <= 1.0, 0.5 * r * r, r - 0.5)
        r2 = r * r
        return r2 / (1.0 + r2)

    def value(self, pixels: np.ndarray, observed: np.ndarray, height_px: np.ndarray) -> np.ndarray:
        """The keypoint term (unweighted) of n candidates.

        Args:
            pixels: (n, C, K, 2) float32 projected model points (NaN behind the camera).
            observed: (C, K, 3) detected u, v (px) and confidence in [0, 1].
            height_px: (C,) the person's image height per camera, px (> 0).

        Returns:
            (n,) float64, 0 where no keypoint is confident.
        """
        w = observed[..., 2]
        total = w.sum()
        if total <= 0:
            return np.zeros(len(pixels))
        pixels = np.ascontiguousarray(pixels)  # the sums below run in memory order: the same for every backend
        d = np.hypot(pixels[..., 0] - observed[..., 0], pixels[..., 1] - observed[..., 1])
        r = d / (self.scale * height_px[:, None])
        r = np.where(np.isnan(r), 1.0 / self.scale, r)
        return self.rho(r).reshape(len(pixels), w.size) @ w.ravel() / total


@dataclass(frozen=True)
class Keypoints:
    """One frame's 2-D keypoints in C cameras, mapped onto the model's points.

    Attributes:
        points: K model point names (:data:`mmocap.body.keypoints.MODEL_POINTS`).
        offsets_mm: (K, 3) each detector joint's definition offset from its model point, in
            the rest frame, mm.
        observed: (C, K, 3) u, v in px of the ideal (undistorted) camera and the
            confidence in [0, 1]; 0 where the keypoint was not seen.
        term: the weight and loss of the keypoint term.
    """

    points: tuple[str, ...]
    offsets_mm: np.ndarray
    observed: np.ndarray
    term: KeypointTerm

    def __post_init__(self):
        observed = np.asarray(self.observed, np.float64)
        K = len(self.points)
        if observed.ndim != 3 or observed.shape[1:] != (K, 3):
            raise DataError(f"keypoints: observed must be (cameras, {K}, 3), got shape {observed.shape}")
        w = observed[..., 2]
        if not np.all((w >= 0) & (w <= 1)):
            raise DataError("keypoints: a confidence lies outside [0, 1]")
        if not np.isfinite(observed[..., :2][w > 0]).all():
            raise DataError("keypoints: a confident keypoint has NaN or infinite coordinates")
        object.__setattr__(self, "observed", observed)
        object.__setattr__(self, "offsets_mm", np.asarray(self.offsets_mm, np.float64).reshape(K, 3))

    def select(self, cameras: list[int]) -> Keypoints:
        """The keypoints of the cameras with these indices, in this order."""
        return Keypoints(self.points, self.offsets_mm, self.observed[list(cameras)], self.term)

    def on(self, cameras: list, shrunk: list) -> Keypoints:
        """The keypoints in ``shrunk`` cameras (:meth:`mmocap.camera.Camera.shrunk` of
        ``cameras``), pixel centres kept at integer coordinates."""
        observed = self.observed.copy()
        for c, (big, small) in enumerate(zip(cameras, shrunk)):
            observed[c, :, :2] = big.shrunk_pixels(observed[c, :, :2], small)
        return Keypoints(self.points, self.offsets_mm, observed, self.term)


def person_height_px(mask: np.ndarray) -> float:
    """The height (px) of the foreground's bounding box in an (H, W) mask; the image's
    height when the mask is empty."""
    rows = np.flatnonzero(np.asarray(mask).any(axis=1))
    return float(rows[-1] - rows[0] + 1) if rows.size else float(mask.shape[0])
