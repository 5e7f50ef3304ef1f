"""Figures of a tracking run: error per frame, and the tracked model over camera images."""
from __future__ import annotations

from pathlib import Path

import cv2
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from mmocap.body.skeleton import PARENT_INDEX  # noqa: E402


def plot_error_per_frame(errors_mm: np.ndarray, path: Path, title: str) -> None:
    """Line plot of the marker error (mm) per frame with its mean."""
    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=110)
    ax.plot(np.arange(len(errors_mm)), errors_mm, lw=1.4, label="marker error")
    ax.axhline(np.nanmean(errors_mm), color="tab:red", ls="--", lw=1,
               label=f"mean {np.nanmean(errors_mm):.1f} mm")
    ax.set_xlabel("frame")
    ax.set_ylabel("error (mm)")
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def overlay(image: np.ndarray, camera, silhouette: np.ndarray, joints_mm: np.ndarray,
            truth_markers_mm: np.ndarray | None = None) -> np.ndarray:
    """BGR image (ideal pin-hole geometry) with the model's outline and skeleton drawn on.

    Args:
        image: (H, W) or (H, W, 3) uint8, already undistorted.
        camera: the ideal camera.
        silhouette: (H, W) bool model silhouette.
        joints_mm: (16, 3) estimated joint positions.
        truth_markers_mm: optional (M, 3) true markers, drawn as small crosses.
    """
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    tint = out.copy()
    tint[silhouette] = (0.5 * tint[silhouette] + 0.5 * np.array([255, 160, 0])).astype(np.uint8)
    out = cv2.addWeighted(tint, 0.6, out, 0.4, 0)
    contours, _ = cv2.findContours(silhouette.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    cv2.drawContours(out, contours, -1, (255, 200, 0), 1, cv2.LINE_AA)
    uv = camera.project(joints_mm)
    for j, p in enumerate(PARENT_INDEX):
        if p >= 0:
            cv2.line(out, tuple(np.round(uv[p]).astype(int)), tuple(np.round(uv[j]).astype(int)),
                     (0, 255, 255), 2, cv2.LINE_AA)
    for point in uv:
        cv2.circle(out, tuple(np.round(point).astype(int)), 3, (0, 0, 255), -1, cv2.LINE_AA)
    if truth_markers_mm is not None:
        for point in camera.project(truth_markers_mm[~np.isnan(truth_markers_mm).any(axis=1)]):
            cv2.drawMarker(out, tuple(np.round(point).astype(int)), (0, 255, 0), cv2.MARKER_CROSS, 7, 1)
    return out
