"""Figures of a tracking run (error per frame, the tracked model over camera images, the 3-D
skeleton as a strip of stick figures or an animation), of a sweep (error box plots, error
curves of several algorithms, time-vs-error Pareto front) and of the evaluator benchmark
(frames per second).

Every ``plot_*`` function saves its figure (:func:`_save`) and returns it, closed: the saved
image is the whole canvas (constrained layout, no cropping), legends lie outside the axes,
below them, so that they hide no data, and the figure grows to hold them.
"""
from __future__ import annotations

import io
import warnings
from pathlib import Path

import cv2
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.legend import Legend  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
from PIL import Image  # noqa: E402
from tqdm.auto import tqdm  # noqa: E402

from mmocap.body.skeleton import PARENT_INDEX  # noqa: E402
from mmocap.errors import ConfigError, DataError, MmocapWarning  # noqa: E402
from mmocap.io import atomic_writer  # noqa: E402
from mmocap.validate import check_flag, check_number  # noqa: E402
from mmocap.video import write_video  # noqa: E402

#: magnitude above which a value is plotted in units of a power of ten (:func:`_axis_units`)
PLOTTABLE_MAGNITUDE = 1e300
#: room (inches) kept free at each side of a legend below the axes
LEGEND_MARGIN_INCHES = 0.1
#: size (inches) of one stick figure of :func:`plot_skeleton_strip`, and its resolution
SKELETON_PANEL_INCHES = (2.4, 3.4)
SKELETON_DPI = 100
#: stick figures drawn by :func:`plot_skeleton_strip` when neither frames nor every is given
SKELETON_STRIP_FRAMES = 8
#: the most stick figures one strip may hold
SKELETON_STRIP_MAX_FRAMES = 24
#: size (inches) and resolution of :func:`write_skeleton_animation`'s frames: 480 x 480 pixels,
#: a multiple of the 16-pixel blocks of H.264
SKELETON_ANIMATION_INCHES = 4.8
SKELETON_ANIMATION_DPI = 100
#: the most frames per second a GIF plays: its delays are whole hundredths of a second, and
#: browsers show delays under two hundredths at a tenth of a second
GIF_MAX_FPS = 50
#: room (mm) around the joints in a stick figure's box
SKELETON_MARGIN_MM = 100.0
#: magnification of a stick figure's 3-D box in its axes: below 1 to keep the axis labels inside
#: it, as constrained layout does not know where mplot3d will draw them
SKELETON_ZOOM = 0.92
#: camera of the stick figures: degrees above the ground, and azimuth (looking at the model's
#: front, from its left)
SKELETON_VIEW = dict(elev=12.0, azim=115.0)


def plot_error_per_frame(errors_mm: np.ndarray, path: Path, title: str) -> Figure:
    """Line plot of the marker error (mm, shape (frames,)) per frame with its mean; returns the
    saved (closed) figure."""
    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=110, layout="constrained")
    ax.plot(np.arange(len(errors_mm)), errors_mm, lw=1.4, label="marker error")
    ax.axhline(np.nanmean(errors_mm), color="tab:red", ls="--", lw=1,
               label=f"mean {np.nanmean(errors_mm):.1f} mm")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("frame")
    ax.set_ylabel("error (mm)")
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    _legend_below(fig, *ax.get_legend_handles_labels())
    return _save(fig, path, None)


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
    _draw_projected_skeleton(out, camera, joints_mm, truth_markers_mm)
    return out


#: BGR colours of :func:`comparison_overlay`: foreground the model misses, model outside the
#: foreground, and their overlap
COMPARISON_COLOURS = {"foreground only": (255, 90, 0), "model only": (0, 0, 255), "both": (0, 200, 0)}


def comparison_overlay(image: np.ndarray, camera, foreground: np.ndarray, silhouette: np.ndarray,
                       joints_mm: np.ndarray, truth_markers_mm: np.ndarray | None = None,
                       lines: tuple[str, ...] = ()) -> np.ndarray:
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
    """
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    foreground, silhouette = np.asarray(foreground, bool), np.asarray(silhouette, bool)
    tint = out.copy()
    for (_, colour), where in zip(COMPARISON_COLOURS.items(),
                                  (foreground & ~silhouette, silhouette & ~foreground, foreground & silhouette)):
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


def _draw_projected_skeleton(out: np.ndarray, camera, joints_mm: np.ndarray,
                             truth_markers_mm: np.ndarray | None) -> None:
    """The skeleton's bones (yellow) and joints (red) of ``joints_mm`` (16, 3) mm, and the true
    markers (green crosses) of ``truth_markers_mm`` (M, 3) mm, drawn into ``out`` in place."""
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


def plot_error_curves(errors_mm: pd.DataFrame, path: Path, title: str,
                      spread: tuple[pd.DataFrame, pd.DataFrame] | None = None,
                      note: str | None = None) -> Figure:
    """Marker error (mm) per frame of several algorithms (Yeguas Fig. 10); returns the saved
    (closed) figure.

    Args:
        errors_mm: (frames, algorithms) errors, index = frame number, one column per line.
        spread: optional (low, high) frames of the same shape, drawn as a band per line.
        note: provenance, stored as the PNG's Description.
    """
    fig, ax = plt.subplots(figsize=(9, 3.8), dpi=110, layout="constrained")
    for name in errors_mm.columns:
        line, = ax.plot(errors_mm.index, errors_mm[name], lw=1.4,
                        label=f"{name} (mean {errors_mm[name].mean():.1f} mm)")
        if spread is not None:
            ax.fill_between(errors_mm.index, spread[0][name], spread[1][name], color=line.get_color(),
                            alpha=0.15, lw=0)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("frame")
    ax.set_ylabel("marker error (mm)")
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    _legend_below(fig, *ax.get_legend_handles_labels())
    return _save(fig, path, note)


def plot_grouped_boxplots(data: pd.DataFrame, path: Path, *, value: str, x: str, hue: str,
                          panel: list[str], ylabel: str, title: str, note: str | None = None) -> Figure:
    """Box plots of ``value``, panels stacked vertically (Yeguas Fig. 7); returns the saved
    (closed) figure.

    One panel per combination of the ``panel`` columns; in each, the ``x`` values along the
    axis and, at each, one box per ``hue`` value present in the panel (one colour per hue
    value across panels). Whiskers span the minimum and the maximum, the box the quartiles,
    the line inside the median. Categorical columns keep their category order, others are
    sorted. ``note`` (provenance) is stored as the PNG's Description.
    """
    xs, hues = _levels(data[x]), _levels(data[hue])
    palette = plt.get_cmap("tab10" if len(hues) <= 10 else "tab20")
    colours = dict(zip(hues, palette(np.arange(len(hues)) % 20)))
    panels = list(data.groupby(panel, observed=True, sort=True))
    widest = max(panel_data[hue].nunique() for _, panel_data in panels)
    fig, axes = plt.subplots(len(panels), 1, squeeze=False, sharey=True, dpi=100, layout="constrained",
                             figsize=(min(24.0, max(7.0, 0.22 * len(xs) * widest + 1.5)),
                                      2.6 * len(panels) + 0.6))
    for ax, (key, panel_data) in zip(axes[:, 0], panels):
        present = [h for h in hues if (panel_data[hue] == h).any()]
        width = 0.8 / len(present)
        for h, name in enumerate(present):
            groups = [panel_data.loc[(panel_data[x] == v) & (panel_data[hue] == name), value].to_numpy()
                      for v in xs]
            positions = [k - 0.4 + width * (h + 0.5) for k, g in enumerate(groups) if len(g)]
            ax.boxplot([g for g in groups if len(g)], positions=positions, widths=width * 0.85,
                       whis=(0, 100), patch_artist=True, manage_ticks=False,
                       boxprops=dict(facecolor=colours[name], lw=0.8),
                       medianprops=dict(color="black", lw=1), whiskerprops=dict(lw=0.8),
                       capprops=dict(lw=0.8))
        ax.set_xticks(range(len(xs)), [str(v) for v in xs])
        ax.set_xlim(-0.5, len(xs) - 0.5)
        ax.set_title(", ".join(map(str, key if isinstance(key, tuple) else (key,))), fontsize=10)
        ax.set_ylabel(ylabel)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(title)
    _legend_below(fig, [plt.Rectangle((0, 0), 1, 1, facecolor=colours[h]) for h in hues],
                  [str(h) for h in hues], fontsize=9)
    return _save(fig, path, note)


def plot_pareto_front(table: pd.DataFrame, path: Path, *, title: str, note: str | None = None,
                      x: str = "seconds_per_frame", y: str = "mean_marker_error_mm",
                      colour: str = "backend") -> Figure:
    """Time against error of every configuration, the Pareto front linked (Cano Fig. 4);
    returns the saved (closed) figure.

    ``table`` holds one row per configuration: ``vertices`` (marker shape), ``colour`` (a
    column, ``backend`` by default), ``evaluations`` (written beside the point), ``x``, ``y``
    and ``pareto`` (bool).
    ``note`` (provenance) is stored as the PNG's Description. Values near the float limit are
    plotted in units of a power of ten that the axis label names.
    """
    (x_factor, x_unit), (y_factor, y_unit) = _axis_units(table[x]), _axis_units(table[y])
    table = table.assign(**{x: table[x] / x_factor, y: table[y] / y_factor})
    backends, meshes = sorted(table[colour].unique()), sorted(table["vertices"].unique())
    colours = dict(zip(backends, plt.get_cmap("tab10")(np.arange(len(backends)) % 10)))
    markers = dict(zip(meshes, "os^Dvp*hX"))
    fig, ax = plt.subplots(figsize=(8, 5), dpi=110, layout="constrained")
    front = table[table["pareto"]].sort_values(x)
    ax.plot(front[x], front[y], color="0.3", lw=1.2, ls="--", zorder=1, label="Pareto front")
    for row in table.itertuples(index=False):
        ax.scatter(getattr(row, x), getattr(row, y), color=colours[getattr(row, colour)],
                   marker=markers[row.vertices], s=70 if row.pareto else 35,
                   edgecolors="black" if row.pareto else "none", zorder=2)
        ax.annotate(f"{row.evaluations}", (getattr(row, x), getattr(row, y)), fontsize=7,
                    xytext=(4, 3), textcoords="offset points")
    handles = [plt.Line2D([], [], color="0.3", ls="--", label="Pareto front")]
    handles += [plt.Line2D([], [], ls="", marker="o", color=colours[b], label=f"{colour} {b}")
                for b in backends]
    handles += [plt.Line2D([], [], ls="", marker=markers[v], color="0.5", label=f"{v} vertices")
                for v in meshes]
    if table[x].max() > 20 * table[x].min() > 0:
        ax.set_xscale("log")
    ax.set_xlabel(f"time per frame (s){x_unit}")
    ax.set_ylabel(f"mean marker error (mm){y_unit}")
    ax.set_title(f"{title}\n(numbers: evaluations per frame; outlined: non-dominated)", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    _legend_below(fig, handles, [h.get_label() for h in handles])
    return _save(fig, path, note)


def _axis_units(values: pd.Series) -> tuple[float, str]:
    """The factor to divide ``values`` by before plotting them, and the axis label's note of it:
    1 and '' unless they exceed :data:`PLOTTABLE_MAGNITUDE`, where matplotlib's tick arithmetic
    overflows; then the power of ten of the largest, e.g. 1e307 and ' (x 1e307)'."""
    largest = float(np.abs(values).max())
    if not largest > PLOTTABLE_MAGNITUDE:
        return 1.0, ""
    exponent = int(np.floor(np.log10(largest)))
    return 10.0 ** exponent, f" (x 1e{exponent})"


def plot_frames_per_second(table: pd.DataFrame, path: Path, *, title: str,
                           note: str | None = None) -> Figure:
    """Frames per second against evaluations per frame (Cano Fig. 3), log-log: one colour per
    ``backend``, one marker per ``vertices``; rows with ``extrapolated`` drawn dashed. Returns
    the saved (closed) figure."""
    backends, meshes = list(dict.fromkeys(table["backend"])), sorted(table["vertices"].unique())
    colours = dict(zip(backends, plt.get_cmap("tab10")(np.arange(len(backends)) % 10)))
    markers = dict(zip(meshes, "os^Dvp*hX"))
    fig, ax = plt.subplots(figsize=(9.5, 5), dpi=110, layout="constrained")
    for (backend, vertices), rows in table.groupby(["backend", "vertices"], sort=False):
        rows = rows.sort_values("evaluations")
        ax.plot(rows["evaluations"], rows["fps"], color=colours[backend], marker=markers[vertices],
                ls="--" if rows["extrapolated"].any() else "-", lw=1.3, ms=6)
    handles = [plt.Line2D([], [], color=colours[b], label=b) for b in backends]
    handles += [plt.Line2D([], [], ls="", marker=markers[v], color="0.5", label=f"{v} vertices")
                for v in meshes]
    if table["extrapolated"].any():
        handles.append(plt.Line2D([], [], color="0.5", ls="--", label="extrapolated"))
    ax.set_xscale("log")
    ax.set_yscale("log")
    budgets = sorted(table["evaluations"].unique())
    ax.set_xticks(budgets, [str(b) for b in budgets])
    ax.minorticks_off()
    ax.set_xlabel("evaluations per frame")
    ax.set_ylabel("frames per second")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, which="both")
    _legend_below(fig, handles, [h.get_label() for h in handles])
    return _save(fig, path, note)


def plot_skeleton_strip(joints_mm: np.ndarray, parents: np.ndarray, path: Path, title: str,
                        frames=None, every: int | None = None) -> Figure:
    """A strip of 3-D stick figures, one per frame drawn, titled with its frame number; returns
    the saved (closed) figure.

    Args:
        joints_mm: (F, J, 3) joint positions, world mm, Y up (x: the model's left, z: its
            front); drawn with x and z on the ground and y up.
        parents: (J,) index of each joint's parent, -1 for the root
            (:data:`mmocap.body.skeleton.PARENT_INDEX`).
        path: the image to write (``.png``), atomically.
        frames: the frame indices (0-based, into ``joints_mm``) to draw; or
        every: draw every ``every``-th frame from the first. Neither: :data:`SKELETON_STRIP_FRAMES`
            frames spaced evenly from the first to the last.

    Every figure has the same scale on its three axes and across the strip (a box of the same
    size, centred on the model on the ground, over the height of all the frames drawn). At most
    :data:`SKELETON_STRIP_MAX_FRAMES` figures: more is a ConfigError.
    """
    joints_mm, parents = _checked_skeleton(joints_mm, parents)
    shown = _strip_frames(len(joints_mm), frames, every)
    ground_span, height = _skeleton_box(joints_mm[shown])
    width, tall = SKELETON_PANEL_INCHES
    fig = plt.figure(figsize=(width * len(shown), tall), dpi=SKELETON_DPI, layout="constrained")
    for k, frame in enumerate(shown):
        ax = fig.add_subplot(1, len(shown), k + 1, projection="3d")
        _draw_skeleton(ax, joints_mm[frame], parents)
        _frame_skeleton(ax, joints_mm[frame], ground_span, height)
        ax.set_title(f"frame {frame}", fontsize=9)
    fig.suptitle(title)
    return _save(fig, path, None)


def write_skeleton_animation(joints_mm: np.ndarray, parents: np.ndarray, path: Path, fps: float,
                             *, title: str = "", progress: bool = True) -> Path:
    """An animation of the 3-D stick figure, one image per frame of ``joints_mm``, titled with
    the frame number, drawn as :func:`plot_skeleton_strip` draws one (the box follows the model
    over the ground, its height fixed); returns ``path``.

    ``path`` ending in ``.gif``: an animated GIF, made with Pillow in memory (as matplotlib's
    PillowWriter does: about 0.2 MB per frame; above :data:`GIF_MAX_FPS` frames per second it
    plays slower, with a warning); ``.mp4``: a video written as it goes by
    :func:`mmocap.video.write_video` (H.264 with the ``video`` extra), read back to check that
    it holds every frame. Either is written to a temporary file beside ``path`` and renamed to it when complete.

    Args:
        joints_mm: (F, J, 3) joint positions, world mm, Y up (as :func:`plot_skeleton_strip`).
        parents: (J,) index of each joint's parent, -1 for the root.
        fps: frames per second it plays at.
        title: drawn above the frame number.
        progress: show a progress bar.
    """
    joints_mm, parents = _checked_skeleton(joints_mm, parents)
    fps = check_number("fps", fps, 0, low_open=True)
    progress = check_flag("progress", progress)
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ConfigError(f"{path}: a skeleton animation is written as .gif or .mp4, not "
                          f"{path.suffix or 'a file without a suffix'}; name it <name>.gif or <name>.mp4")
    if suffix == ".gif" and fps > GIF_MAX_FPS:
        warnings.warn(f"{path}: a GIF plays at most {GIF_MAX_FPS} frames per second, so it will play "
                      f"slower than {fps:g}; write an .mp4 instead", MmocapWarning, stacklevel=2)
    images = _skeleton_images(joints_mm, parents, title,
                              tqdm(range(len(joints_mm)), desc=f"animate {path.name}", unit="frame",
                                   disable=not progress))
    if suffix == ".gif":
        _write_gif(path, images, fps)
    else:
        write_video(path, (image[..., ::-1] for image in images), fps)  # RGB -> BGR
    return path


def _checked_skeleton(joints_mm, parents) -> tuple[np.ndarray, np.ndarray]:
    """``joints_mm`` as a float (F, J, 3) array and ``parents`` as an int (J,) array, each
    parent -1 or another joint; a DataError saying what is wrong if not, or if a frame has
    no finite joint."""
    joints_mm, parents = np.asarray(joints_mm, dtype=float), np.asarray(parents)
    if joints_mm.ndim != 3 or joints_mm.shape[2] != 3 or len(joints_mm) == 0:
        raise DataError(f"joints_mm must be (frames, joints, 3) with at least one frame, got shape "
                        f"{joints_mm.shape}")
    count = joints_mm.shape[1]
    if (parents.shape != (count,) or not np.issubdtype(parents.dtype, np.integer)
            or ((parents < -1) | (parents >= count) | (parents == np.arange(count))).any()):
        raise DataError(f"parents must hold one integer per joint ({count}), each -1 (the root) or the "
                        f"index of another joint, got {parents.tolist()}")
    empty = np.flatnonzero(~np.isfinite(joints_mm).all(axis=2).any(axis=1))
    if len(empty):
        raise DataError(f"joints_mm: frames {', '.join(map(str, empty[:10]))} have no finite joint "
                        "to draw")
    return joints_mm, parents


def _strip_frames(count: int, frames, every: int | None) -> list[int]:
    """The frame indices a strip of a ``count``-frame sequence draws (:func:`plot_skeleton_strip`)."""
    if frames is not None and every is not None:
        raise ConfigError(f"give the frames of a skeleton strip or every, not both (got frames={frames!r}, "
                          f"every={every!r})")
    if frames is not None:
        shown = [check_number("frames", f, 0, count - 1, integer=True) for f in frames]
    elif every is not None:
        shown = list(range(0, count, check_number("every", every, 1, integer=True)))
    else:
        shown = sorted(set(np.linspace(0, count - 1, min(count, SKELETON_STRIP_FRAMES)).round().astype(int)))
    if not 1 <= len(shown) <= SKELETON_STRIP_MAX_FRAMES:
        raise ConfigError(f"a skeleton strip draws 1 to {SKELETON_STRIP_MAX_FRAMES} frames, these settings "
                          f"draw {len(shown)} of {count}; give fewer frames or a larger every")
    return [int(f) for f in shown]


def _skeleton_box(joints_mm: np.ndarray) -> tuple[float, tuple[float, float]]:
    """Of (F, J, 3) joints: the side (mm) of the square of ground that holds the model in any
    of the frames, and the (bottom, top) of a height that holds it in all of them."""
    extent = np.nanmax(joints_mm, axis=1) - np.nanmin(joints_mm, axis=1)  # (F, 3)
    ground_span = float(np.max(extent[:, [0, 2]])) + 2 * SKELETON_MARGIN_MM
    return ground_span, (float(np.nanmin(joints_mm[..., 1])) - SKELETON_MARGIN_MM,
                         float(np.nanmax(joints_mm[..., 1])) + SKELETON_MARGIN_MM)


def _bones(joints_mm: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """(3 B, 3) the bones of (J, 3) joints as one polyline: each bone's two ends, then a NaN."""
    children = np.flatnonzero(parents >= 0)
    ends = np.stack([joints_mm[parents[children]], joints_mm[children],
                     np.full((len(children), 3), np.nan)], axis=1)
    return ends.reshape(-1, 3)


def _draw_skeleton(ax, joints_mm: np.ndarray, parents: np.ndarray) -> tuple:
    """Draw (J, 3) joints and their bones on a 3-D axes, x and z (world) on its ground, y up;
    returns the (bones, joints) lines."""
    bones = _bones(joints_mm, parents)
    bone_line, = ax.plot(bones[:, 0], bones[:, 2], bones[:, 1], color="tab:blue", lw=2)
    joint_line, = ax.plot(joints_mm[:, 0], joints_mm[:, 2], joints_mm[:, 1], ls="", marker="o", ms=3,
                          color="tab:red")
    return bone_line, joint_line


def _frame_skeleton(ax, joints_mm: np.ndarray, ground_span: float, height: tuple[float, float]) -> None:
    """Limits of a 3-D axes around (J, 3) joints: a ``ground_span`` square centred on them,
    ``height`` up, on one scale; x runs from right to left so that the world's right-handed
    axes are not drawn mirrored, as the plot's y is the world's z."""
    centre = (np.nanmin(joints_mm, axis=0) + np.nanmax(joints_mm, axis=0)) / 2
    ax.set_xlim(centre[0] + ground_span / 2, centre[0] - ground_span / 2)
    ax.set_ylim(centre[2] - ground_span / 2, centre[2] + ground_span / 2)
    ax.set_zlim(*height)
    ax.set_box_aspect((ground_span, ground_span, height[1] - height[0]), zoom=SKELETON_ZOOM)
    ax.view_init(**SKELETON_VIEW)
    for axis, name in ((ax.xaxis, "x"), (ax.yaxis, "z"), (ax.zaxis, "y")):
        axis.set_major_locator(MaxNLocator(4 if name == "y" else 3))
        axis.set_label_text(f"{name} (mm)", fontsize=7)
        axis.labelpad = -4
    ax.tick_params(labelsize=5, pad=-1)


def _skeleton_images(joints_mm: np.ndarray, parents: np.ndarray, title: str, frames):
    """Yield the (H, W, 3) uint8 RGB image of the stick figure of each frame in ``frames``."""
    ground_span, height = _skeleton_box(joints_mm)
    fig = plt.figure(figsize=(SKELETON_ANIMATION_INCHES,) * 2, dpi=SKELETON_ANIMATION_DPI,
                     layout="constrained")
    try:
        ax = fig.add_subplot(projection="3d")
        bone_line, joint_line = _draw_skeleton(ax, joints_mm[0], parents)
        for frame in frames:
            bones = _bones(joints_mm[frame], parents)
            bone_line.set_data_3d(bones[:, 0], bones[:, 2], bones[:, 1])
            joint_line.set_data_3d(joints_mm[frame, :, 0], joints_mm[frame, :, 2], joints_mm[frame, :, 1])
            _frame_skeleton(ax, joints_mm[frame], ground_span, height)
            ax.set_title(f"{title}\nframe {frame}" if title else f"frame {frame}", fontsize=10)
            fig.canvas.draw()
            yield np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()  # type: ignore[attr-defined]  # Agg canvas
    finally:
        plt.close(fig)


def _write_gif(path: Path, images, fps: float) -> None:
    """Write RGB images as an endlessly looping GIF at ``fps`` atomically. Pillow directly, as
    the temporary file has no ``.gif`` suffix for matplotlib's PillowWriter to go by."""
    frames = [Image.fromarray(image).convert("P", palette=Image.Palette.ADAPTIVE) for image in images]
    encoded = io.BytesIO()
    frames[0].save(encoded, format="GIF", save_all=True, append_images=frames[1:],
                   duration=round(1000 / fps), loop=0)
    with atomic_writer(path, "wb") as f:
        f.write(encoded.getvalue())


def _legend_below(fig: Figure, handles, labels, fontsize: float = 8) -> Legend:
    """A legend for the whole figure, below its axes (so that it hides none of their data), in
    as many columns as its width holds; the figure is widened to hold the widest entry and made
    taller by the legend's height, so that the axes keep theirs (constrained layout)."""
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]  # Agg canvas
    one_column = fig.legend(handles, labels, loc="outside lower center", fontsize=fontsize, ncols=1)
    column_px = one_column.get_window_extent(renderer).width
    one_column.remove()
    spacing_px = matplotlib.rcParams["legend.columnspacing"] * fontsize * fig.dpi / 72
    margin_px = 2 * LEGEND_MARGIN_INCHES * fig.dpi
    if column_px + margin_px > fig.bbox.width:
        fig.set_figwidth((column_px + margin_px) / fig.dpi)
    fitting = max(1, int((fig.bbox.width - margin_px + spacing_px) // (column_px + spacing_px)))
    rows = -(-len(labels) // fitting)
    legend = fig.legend(handles, labels, loc="outside lower center", fontsize=fontsize,
                        ncols=-(-len(labels) // rows))
    fig.set_figheight(fig.get_figheight() + legend.get_window_extent(renderer).height / fig.dpi)
    return legend


def _levels(column: pd.Series) -> list:
    """The distinct values of a column: in category order if categorical, else sorted."""
    if isinstance(column.dtype, pd.CategoricalDtype):
        return [c for c in column.cat.categories if (column == c).any()]
    return sorted(column.unique())


def _save(fig: Figure, path: Path, note: str | None) -> Figure:
    """Write ``fig`` (the whole canvas) atomically in the format of ``path``'s suffix
    (:func:`mmocap.io.atomic_writer`: a WriteError naming it if it cannot be written), ``note``
    as its Description; close it and return it."""
    path = Path(path)
    try:
        with atomic_writer(path, "wb") as f:
            fig.savefig(f, format=path.suffix.lstrip(".") or None,
                        metadata={"Description": note} if note else None)
    finally:
        plt.close(fig)
    return fig
