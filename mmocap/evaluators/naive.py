"""Reference evaluator: the rule of :mod:`mmocap.evaluators.silhouette` as plain loops.

Slow (a Python loop over every vertex of every view; ``make bench`` times it) and meant to
be read and trusted: every other backend is tested against its pixel counts
(:mod:`mmocap.testing.evaluators`).
"""

from __future__ import annotations

import math

import numpy as np

from mmocap.evaluators.silhouette import (
    NEAR_MM,
    SilhouetteEvaluator,
    vertex_table,
    view_geometry,
)

ONE, HALF, NEAR = np.float32(1.0), np.float32(0.5), np.float32(NEAR_MM)


class NaiveEvaluator(SilhouetteEvaluator):
    """Loops over candidates, cameras and vertices, stamping each patch into a bool image.

    Args:
        patch_scale: factor on the body's per-joint patch size (Cano Eq. 4), > 0.
    """

    name = "naive"

    def _prepare(self) -> None:
        self._table = vertex_table(self.body, self.patch_scale)

    def _counts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        coefficients, side = view_geometry(self.body, self.cameras, X, self.patch_scale)
        n, C = len(X), len(self.cameras)
        model_px = np.zeros((n, C), dtype=np.int64)
        overlap_px = np.zeros((n, C), dtype=np.int64)
        for i in range(n):
            for c in range(C):
                silhouette = self._silhouette(coefficients[i, c], side[i, c], self.cameras[c])
                model_px[i, c] = np.count_nonzero(silhouette)
                overlap_px[i, c] = np.count_nonzero(silhouette & self.foreground[c])
        return model_px, overlap_px

    def _render(self, x: np.ndarray, camera_index: int) -> np.ndarray:
        camera = self.cameras[camera_index]
        coefficients, side = view_geometry(self.body, [camera], x[None], self.patch_scale)
        return self._silhouette(coefficients[0, 0], side[0, 0], camera)

    def _silhouette(self, coefficients: np.ndarray, side: np.ndarray, camera) -> np.ndarray:
        """(J, 16) float32 projection coefficients and (J,) patch sides of one view -> (H, W)
        bool model silhouette."""
        H, W = camera.height, camera.width
        image = np.zeros((H, W), dtype=bool)
        table = self._table
        for k, j in enumerate(self.body.vertex_joint):
            s = int(side[j])
            if s == 0:
                continue
            # steps 3-4 in float32 (NumPy float32 scalars), as the rule writes them
            a00, a01, a02, a03, a10, a11, a12, a13, a20, a21, a22, a23, b0, b1, b2, _ = coefficients[j]
            x, y, z, nx, ny, nz, nv = table[:, k]
            if not nv + (nx * b0 + ny * b1 + nz * b2) < 0:
                continue
            depth = a20 * x + a21 * y + a22 * z + a23
            if not depth > NEAR:
                continue
            r = ONE / depth
            cx = math.floor((a00 * x + a01 * y + a02 * z + a03) * r + HALF)
            cy = math.floor((a10 * x + a11 * y + a12 * z + a13) * r + HALF)
            col0, col1 = max(cx - (s - 1) // 2, 0), min(cx + s // 2, W - 1)
            row0, row1 = max(cy - (s - 1) // 2, 0), min(cy + s // 2, H - 1)
            if col0 <= col1 and row0 <= row1:
                image[row0 : row1 + 1, col0 : col1 + 1] = True
        return image
