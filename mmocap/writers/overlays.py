"""The tracked model drawn over the camera images of a run: the overlay images
(``overlays/frame_*.png``) and the frames of the comparison videos (:mod:`mmocap.writers.videos`).

Every image is BGR uint8 in the ideal (undistorted) pin-hole geometry of its camera; joints
and markers are in world mm.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from mmocap.body.skeleton import PARENT_INDEX
from mmocap.errors import DataError
from mmocap.io import write_image


def overlay(
    image: np.ndarray, camera, silhouette: np.ndarray, joints_mm: np.ndarray, truth_markers_mm: np.ndarray | None = None
) -> np.ndarray:
    """BGR image (ideal pin-hole geometry) with the model's outline and skeleton drawn on.

    Args:
        image: (H, W) or (H, W, 3) uint8, already undistorted.
        camera: the ideal camera.
        silhouette: (H, W) bool model silhouette.
        joints_mm: (16, 3) estimated joint positions, mm.
        truth_markers_mm: optional (M, 3) true markers, drawn as small crosses.
    """
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    tint = out.copy()
    tint[silhouette] = (0.5 * tint[silhouette] + 0.5 * np.array([255, 160, 0])).astype(np.uint8)
    out = cv2.addWeighted(tint, 0.6, out, 0.4, 0)
    contours, _ = cv2.findContours(silhouette.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    cv2.drawContours(out, contours, -1, (255, 200, 0), 1, cv2.LINE_AA)
    _draw_projected_skeleton(out, camera, joints_mm, truth_markers_mm)
    return out


#: BGR colours of :func:`comparison_overlay`: foreground the model misses, model outside the
#: foreground, and their overlap
COMPARISON_COLOURS = {"foreground only": (255, 90, 0), "model only": (0, 0, 255), "both": (0, 200, 0)}


def comparison_overlay(
    image: np.ndarray,
    camera,
    foreground: np.ndarray,
    silhouette: np.ndarray,
    joints_mm: np.ndarray,
    truth_markers_mm: np.ndarray | None = None,
    lines: tuple[str, ...] = (),
) -> np.ndarray:
    """BGR image (ideal pin-hole geometry) comparing the foreground with the model: pixels of
    the foreground only, of the model only, and of both tinted in the colours of
    :data:`COMPARISON_COLOURS` (with a legend), the skeleton and true markers drawn as
    :func:`overlay` draws them, and ``lines`` of text in the top left corner.

    Args:
        image: (H, W) or (H, W, 3) uint8, already undistorted.
        camera: the ideal camera.
        foreground: (H, W) bool foreground mask.
        silhouette: (H, W) bool model silhouette.
        joints_mm: (16, 3) estimated joint positions, mm.
        truth_markers_mm: optional (M, 3) true markers, mm.
        lines: text lines drawn in the top left corner, one per line.
    """
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    foreground, silhouette = np.asarray(foreground, bool), np.asarray(silhouette, bool)
    tint = out.copy()
    for (_, colour), where in zip(
        COMPARISON_COLOURS.items(), (foreground & ~silhouette, silhouette & ~foreground, foreground & silhouette)
    ):
        tint[where] = colour
    out = cv2.addWeighted(tint, 0.5, out, 0.5, 0)
    _draw_projected_skeleton(out, camera, joints_mm, truth_markers_mm)
    scale = max(0.35, out.shape[0] / 960)
    step = int(22 * scale / 0.5)
    for k, text in enumerate(lines):
        _label(out, text, (8, step * (k + 1)), scale, (255, 255, 255))
    for k, (name, colour) in enumerate(COMPARISON_COLOURS.items()):
        _label(out, name, (8, out.shape[0] - 8 - step * (len(COMPARISON_COLOURS) - 1 - k)), scale, colour)
    return out


def _label(image: np.ndarray, text: str, origin: tuple[int, int], scale: float, colour) -> None:
    """``text`` drawn at ``origin`` in ``colour`` over a dark outline, readable on any image."""
    cv2.putText(image, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(image, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def _draw_projected_skeleton(
    out: np.ndarray, camera, joints_mm: np.ndarray, truth_markers_mm: np.ndarray | None
) -> None:
    """The skeleton's bones (yellow) and joints (red) of ``joints_mm`` (16, 3) mm, and the true
    markers (green crosses) of ``truth_markers_mm`` (M, 3) mm, drawn into ``out`` in place."""
    uv = camera.project(joints_mm)
    for j, p in enumerate(PARENT_INDEX):
        if p >= 0:
            cv2.line(
                out,
                tuple(np.round(uv[p]).astype(int)),
                tuple(np.round(uv[j]).astype(int)),
                (0, 255, 255),
                2,
                cv2.LINE_AA,
            )
    for point in uv:
        cv2.circle(out, tuple(np.round(point).astype(int)), 3, (0, 0, 255), -1, cv2.LINE_AA)
    if truth_markers_mm is not None:
        for point in camera.project(truth_markers_mm[~np.isnan(truth_markers_mm).any(axis=1)]):
            cv2.drawMarker(out, tuple(np.round(point).astype(int)), (0, 255, 0), cv2.MARKER_CROSS, 7, 1)


def write_overlays(folder: Path, sequence, foreground, evaluator, body, results, truth, count: int) -> None:
    """The tracked model over undistorted camera images for ``count`` evenly spaced frames,
    one PNG each, written atomically (a WriteError naming it if it cannot be)."""
    if count == 0:
        return
    cameras = foreground.cameras
    for k in np.unique(np.linspace(0, len(results) - 1, count).round().astype(int)):
        result = results[k]
        evaluator.setup(body, cameras, foreground.masks(result.frame))
        joints = body.joint_positions(result.pose[None])[0]
        tiles = []
        for c, (cam, image) in enumerate(zip(sequence.cameras, sequence.images(result.frame))):
            mx, my = cam.undistort_maps()
            ideal_image = cv2.remap(image, mx, my, cv2.INTER_LINEAR)
            tile = overlay(ideal_image, cameras[c], evaluator.render(result.pose, c), joints, truth[result.frame])
            cv2.putText(
                tile,
                f"{cam.name} frame {result.frame}",
                (8, 20),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.55,
                (255, 255, 255),
                1,
                cv2.LINE_AA,
            )
            tiles.append(tile)
        if not tiles:
            raise DataError("no camera images to draw overlays on")
        write_image(folder / f"frame_{result.frame:06d}.png", _grid(tiles))


def _grid(tiles: list[np.ndarray]) -> np.ndarray:
    """Tiles, resized to the first one's size, in a grid of two columns."""
    h, w = tiles[0].shape[:2]
    tiles = [t if t.shape[:2] == (h, w) else cv2.resize(t, (w, h)) for t in tiles]
    if len(tiles) % 2:
        tiles = tiles + [np.zeros_like(tiles[0])]
    rows = [np.hstack(tiles[i : i + 2]) for i in range(0, len(tiles), 2)]
    return np.vstack(rows)
