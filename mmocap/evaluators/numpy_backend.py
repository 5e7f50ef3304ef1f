"""Vectorised evaluator: the rule of :mod:`mmocap.evaluators.silhouette` with NumPy and OpenCV.

Projection (steps 3-4): :func:`~mmocap.evaluators.silhouette.project`, the rule's float32
arithmetic, for the whole batch of views at once, one joint at a time (vertices are
grouped by joint). Joints dropped by step 2 get a zero depth row and so fail ``z > NEAR_MM``.

Stamping (step 5): the kept centres of all views are written into one tall uint8 canvas,
each view in its own (Hc, Wc) window that covers its centres plus the largest patch reach
``P`` on every side (centres are clamped to at most ``P + 1`` pixels outside the image,
where their patches stay outside it). For each distinct patch side ``s`` the centres of
that side go into a separate canvas dilated with an ``s x s`` kernel; OpenCV's default
anchor ``(s//2, s//2)`` makes a centre at ``x`` cover ``x - (s-1)//2 .. x + s//2`` as
the rule asks. The windows never reach into each other, so one ``cv2.dilate`` per side
serves all views. Counting ANDs each window with the matching window of a padded code
image (1 = inside the image, 3 = inside and foreground).

The keypoint term's pixels (:meth:`NumpyEvaluator._counts_and_pixels`) come from the same
coefficients as the stamping, :func:`~mmocap.evaluators.silhouette.keypoint_pixels` of
them: this backend is the reference of the other backends' pixels.

Views with a patch side above :data:`MAX_DILATE_SIDE` (a body part within a few
centimetres of a camera) are rendered one by one instead, with rectangles summed into a
difference image over the whole image.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

import cv2
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from mmocap.evaluators.silhouette import (
    SilhouetteEvaluator,
    keypoint_pixels,
    project,
    vertex_table,
    view_geometry,
)

MAX_DILATE_SIDE = 33
_MAX_REACH = MAX_DILATE_SIDE // 2
_MARGIN = 2 * _MAX_REACH + 1  # padding of the code images on every side, pixels
_CHUNK = 1 << 21  # views x vertices projected at once (bounds the memory)
_ON = 255  # a covered canvas pixel; ANDed with a code it keeps the code


def keep_freed_memory() -> None:
    """Let glibc reuse freed memory for the per-batch arrays instead of unmapping it.

    Each batch allocates and frees arrays of a few megabytes. Left to itself, glibc serves
    such arrays with fresh mappings and returns them on free until an earlier, larger free
    happens to raise its threshold; when none has, the kernel zero-fills every page again
    and a frame takes markedly longer, much of it in system time.
    This sets the mmap threshold to 32 MiB and the trim threshold to 256 MiB; elsewhere
    than glibc it does nothing.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c"))
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return
    M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
    mallopt(M_MMAP_THRESHOLD, 32 << 20)
    mallopt(M_TRIM_THRESHOLD, 256 << 20)


keep_freed_memory()


class NumpyEvaluator(SilhouetteEvaluator):
    """The silhouette fitness vectorised over population x cameras x vertices.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.
    """

    name = "numpy"

    def _prepare(self) -> None:
        body = self.body
        joint = np.asarray(body.vertex_joint)
        order = np.argsort(joint, kind="stable")
        self._joint = joint[order]
        self._bounds = np.searchsorted(self._joint, np.arange(len(body.joint_rest_positions) + 1))
        self._table = np.ascontiguousarray(vertex_table(body, self.patch_scale)[:, order])  # (7, N)
        self._hmax = max(cam.height for cam in self.cameras)
        self._wmax = max(cam.width for cam in self.cameras)
        pad = 2 * _MARGIN
        codes = np.zeros((len(self.cameras), self._hmax + pad, self._wmax + pad), np.uint8)
        for c, (cam, fg) in enumerate(zip(self.cameras, self.foreground)):
            inside = codes[c, _MARGIN : _MARGIN + cam.height, _MARGIN : _MARGIN + cam.width]
            inside[:] = 1 + 2 * fg.view(np.uint8)
        self._codes = codes

    def _counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        model_px, overlap_px, _ = self._chunked(X, with_pixels=False)
        return model_px, overlap_px

    def _counts_and_pixels(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The counts and the model points' pixels from one :func:`view_geometry` per chunk;
        a subclass that counts its own way (its own ``_counts``) gets the base class's, its
        counts and then the pixels."""
        if type(self)._counts is not NumpyEvaluator._counts:
            return super()._counts_and_pixels(X)
        return self._chunked(X, with_pixels=True)

    def _chunked(self, X: np.ndarray, with_pixels: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n, C) counts and (n, C, K, 2) pixels of the model points, K = 0 unless
        ``with_pixels``, chunk by chunk."""
        step = max(1, _CHUNK // (len(self.cameras) * len(self._joint)))
        parts = [self._chunk_counts(X[i : i + step], with_pixels) for i in range(0, len(X), step)]
        model_px, overlap_px, pixels = (np.concatenate(part) for part in zip(*parts))
        return model_px, overlap_px, pixels

    def _chunk_counts(self, X: np.ndarray, with_pixels: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        cams = np.arange(len(self.cameras))
        n, C = len(X), len(cams)
        geometry = view_geometry(self.body, self.cameras, X, self.patch_scale)
        # the pixels before _stamp, which changes the coefficients of dropped joints
        if with_pixels:
            pixels = keypoint_pixels(geometry[0], self._point_joint, self._point_rest)
        else:
            pixels = np.zeros((n, C, 0, 2), np.float32)
        canvas, oy, ox, exact = self._stamp(X, cams, geometry)
        model_px = np.zeros(n * C, dtype=np.int64)
        overlap_px = np.zeros(n * C, dtype=np.int64)
        if canvas is not None:
            nV, Hc, Wc = canvas.shape
            windows = sliding_window_view(self._codes, (Hc, Wc), axis=(1, 2))
            codes = windows[np.tile(cams, n), oy + _MARGIN, ox + _MARGIN]
            covered = np.bitwise_and(canvas, codes, out=codes)
            overlap = covered == 3
            for view in range(nV):
                model_px[view] = np.count_nonzero(covered[view])
                overlap_px[view] = np.count_nonzero(overlap[view])
        for view, image in exact.items():
            model_px[view] = np.count_nonzero(image)
            overlap_px[view] = np.count_nonzero(image & self.foreground[view % C])
        return model_px.reshape(n, C), overlap_px.reshape(n, C), pixels

    def _render(self, x: np.ndarray, camera_index: int) -> np.ndarray:
        cam = self.cameras[camera_index]
        canvas, oy, ox, exact = self._stamp(x[None], np.array([camera_index]))
        if 0 in exact:
            return exact[0]
        image = np.zeros((cam.height, cam.width), dtype=bool)
        if canvas is not None:
            _, Hc, Wc = canvas.shape
            r0, r1 = max(oy[0], 0), min(oy[0] + Hc, cam.height)
            c0, c1 = max(ox[0], 0), min(ox[0] + Wc, cam.width)
            if r0 < r1 and c0 < c1:
                image[r0:r1, c0:c1] = canvas[0, r0 - oy[0] : r1 - oy[0], c0 - ox[0] : c1 - ox[0]] != 0
        return image

    def _stamp(self, X: np.ndarray, cams: np.ndarray, geometry: tuple[np.ndarray, np.ndarray] | None = None):
        """Silhouettes of poses X (n, P) in cameras ``cams`` (C,): nV = n x C views, ``i * C + c``;
        ``geometry``: their :func:`view_geometry` when already computed (its coefficients
        are changed here).

        Returns:
            canvas: (nV, Hc, Wc) uint8, nonzero = covered, or None when no view has a
                centre on the dilation path; window ``v`` starts at image row ``oy[v]``
                and column ``ox[v]``.
            oy, ox: (nV,) int64 window origins in image pixels (may be negative).
            exact: {view: (H, W) bool} silhouettes of views rendered one by one.
        """
        cameras = [self.cameras[c] for c in cams]
        n, C = len(X), len(cams)
        nV = n * C
        coefficients, side = view_geometry(self.body, cameras, X, self.patch_scale) if geometry is None else geometry
        J = side.shape[2]
        coefficients = coefficients.reshape(nV, J, 16)
        side = side.reshape(nV, J)
        big = (side > MAX_DILATE_SIDE).any(axis=1)
        exact = {
            int(view): _exact_view(coefficients[view], side[view], cameras[view % C], self._table, self._joint)
            for view in np.flatnonzero(big)
        }

        side = np.where(big[:, None], 0, side)  # type: ignore[index]  # sides on the dilation path
        coefficients[side == 0, 8:12] = 0  # depth 0: never kept
        coefficients = np.ascontiguousarray(coefficients.transpose(1, 2, 0))[..., None]  # (J, 16, nV, 1)

        N = self._table.shape[1]
        keep = np.empty((nV, N), bool)
        centres = np.empty((2, nV, N), np.float32)  # cx, cy per view and vertex
        for j in range(J):
            lo, hi = self._bounds[j], self._bounds[j + 1]
            if lo < hi:
                keep[:, lo:hi], centres[0, :, lo:hi], centres[1, :, lo:hi] = project(
                    coefficients[j], self._table[:, lo:hi]
                )
        counts = np.count_nonzero(keep, axis=1)
        oy = np.full(nV, -_MARGIN, dtype=np.int64)
        ox = np.full(nV, -_MARGIN, dtype=np.int64)
        present = np.flatnonzero(counts)
        if present.size == 0:
            return None, oy, ox, exact

        k = np.flatnonzero(keep)  # view * N + vertex
        cx, cy = centres.reshape(2, nV * N).take(k, axis=1)
        sides = np.unique(side[side > 0])
        reach = int(sides[-1]) // 2
        cx = _clamped(cx, reach, self._wmax)
        cy = _clamped(cy, reach, self._hmax)
        starts = np.concatenate([[0], np.cumsum(counts[present])[:-1]])
        xmin, xmax = np.minimum.reduceat(cx, starts), np.maximum.reduceat(cx, starts)
        ymin, ymax = np.minimum.reduceat(cy, starts), np.maximum.reduceat(cy, starts)
        Hc = int((ymax - ymin).max()) + 1 + 2 * reach
        Wc = int((xmax - xmin).max()) + 1 + 2 * reach
        oy[present] = np.minimum(ymin - reach, self._hmax + _MARGIN - Hc)
        ox[present] = np.minimum(xmin - reach, self._wmax + _MARGIN - Wc)
        lin = cy * Wc
        lin += cx
        lin += np.repeat(np.arange(nV) * (Hc * Wc) - oy * Wc - ox, counts)

        if len(sides) > 1:  # one layer per patch side
            layer = np.searchsorted(sides, side).astype(np.uint8)
            lin += np.repeat(layer, np.diff(self._bounds), axis=1).take(k) * np.int64(nV * Hc * Wc)
        layers = np.zeros((len(sides), nV * Hc, Wc), dtype=np.uint8)
        layers.ravel()[lin] = _ON
        for s, image in zip(sides, layers):
            if s > 1:
                cv2.dilate(image, np.ones((s, s), np.uint8), dst=image)
        canvas = np.bitwise_or.reduce(layers, axis=0) if len(sides) > 1 else layers[0]
        return canvas.reshape(nV, Hc, Wc), oy, ox, exact


def _clamped(centre: np.ndarray, reach: int, size: int) -> np.ndarray:
    """(K,) float32 centre pixels -> (K,) int64, clamped to ``[-reach - 1, size + reach]``: a
    clamped centre's patch (reach at most ``reach``) stays outside the image before and
    after clamping."""
    return np.clip(centre, -reach - 1, size + reach).astype(np.int64)


def _exact_view(coefficients: np.ndarray, side: np.ndarray, camera, table: np.ndarray, joint: np.ndarray) -> np.ndarray:
    """One view, any patch sizes: (J, 16) float32 projection coefficients, (J,) sides, the
    (7, N) vertex table and (N,) joint of each vertex -> (H, W) bool silhouette."""
    H, W = camera.height, camera.width
    keep, cx, cy = project(coefficients[joint].T, table)
    s = side[joint]
    keep &= s > 0
    cx, cy, s = cx[keep].astype(np.int64), cy[keep].astype(np.int64), s[keep]
    col0, col1 = np.maximum(cx - (s - 1) // 2, 0), np.minimum(cx + s // 2, W - 1)
    row0, row1 = np.maximum(cy - (s - 1) // 2, 0), np.minimum(cy + s // 2, H - 1)
    ok = (col0 <= col1) & (row0 <= row1)
    col0, col1, row0, row1 = (a[ok].astype(np.int64) for a in (col0, col1, row0, row1))
    # +1 at each rectangle's top-left, -1 right of it and below it, +1 diagonally past it;
    # the 2-D prefix sum then counts the rectangles covering each pixel.
    corners = np.concatenate(
        [row0 * (W + 1) + col0, row0 * (W + 1) + col1 + 1, (row1 + 1) * (W + 1) + col0, (row1 + 1) * (W + 1) + col1 + 1]
    )
    weights = np.repeat([1.0, -1.0, -1.0, 1.0], len(col0))
    diff = np.bincount(corners, weights, minlength=(H + 1) * (W + 1)).reshape(H + 1, W + 1)
    return np.cumsum(np.cumsum(diff, axis=0), axis=1)[:H, :W] > 0.5
