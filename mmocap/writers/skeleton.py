"""Pictures of a run's 3-D skeleton: a strip of stick figures at chosen frames
(``skeleton.png``) and an animation of the whole run (``skeleton.mp4`` or a GIF), drawn by the
rules of :mod:`mmocap.analysis.figures`."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
from PIL import Image  # noqa: E402
from tqdm.auto import tqdm  # noqa: E402

from mmocap.analysis.figures import save_figure  # noqa: E402
from mmocap.errors import ConfigError, DataError, MmocapWarning  # noqa: E402
from mmocap.io import atomic_writer  # noqa: E402
from mmocap.validate import check_flag, check_number  # noqa: E402
from mmocap.video import write_video  # noqa: E402

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


def plot_skeleton_strip(
    joints_mm: np.ndarray, parents: np.ndarray, path: Path, title: str, frames=None, every: int | None = None
) -> Figure:
    """A strip of 3-D stick figures, one per frame drawn, titled with its frame number; returns
    the saved (closed) figure.

    Args:
        joints_mm: (F, J, 3) joint positions, world mm, Y up (x: the model's left, z: its
            front); drawn with x and z on the ground and y up.
        parents: (J,) index of each joint's parent, -1 for the root
            (:data:`mmocap.body.skeleton.PARENT_INDEX`).
        path: the image to write (``.png``), atomically.
        title: drawn above the strip.
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
    return save_figure(fig, path, None)


def write_skeleton_animation(
    joints_mm: np.ndarray, parents: np.ndarray, path: Path, fps: float, *, title: str = "", progress: bool = True
) -> Path:
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
        path: the animation to write, ``.gif`` or ``.mp4``.
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
        raise ConfigError(
            f"{path}: a skeleton animation is written as .gif or .mp4, not "
            f"{path.suffix or 'a file without a suffix'}; name it <name>.gif or <name>.mp4"
        )
    if suffix == ".gif" and fps > GIF_MAX_FPS:
        warnings.warn(
            f"{path}: a GIF plays at most {GIF_MAX_FPS} frames per second, so it will play "
            f"slower than {fps:g}; write an .mp4 instead",
            MmocapWarning,
            stacklevel=2,
        )
    images = _skeleton_images(
        joints_mm,
        parents,
        title,
        tqdm(range(len(joints_mm)), desc=f"animate {path.name}", unit="frame", disable=not progress),
    )
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
        raise DataError(f"joints_mm must be (frames, joints, 3) with at least one frame, got shape {joints_mm.shape}")
    count = joints_mm.shape[1]
    if (
        parents.shape != (count,)
        or not np.issubdtype(parents.dtype, np.integer)
        or ((parents < -1) | (parents >= count) | (parents == np.arange(count))).any()
    ):
        raise DataError(
            f"parents must hold one integer per joint ({count}), each -1 (the root) or the "
            f"index of another joint, got {parents.tolist()}"
        )
    empty = np.flatnonzero(~np.isfinite(joints_mm).all(axis=2).any(axis=1))
    if len(empty):
        raise DataError(f"joints_mm: frames {', '.join(map(str, empty[:10]))} have no finite joint to draw")
    return joints_mm, parents


def _strip_frames(count: int, frames, every: int | None) -> list[int]:
    """The frame indices a strip of a ``count``-frame sequence draws (:func:`plot_skeleton_strip`)."""
    if frames is not None and every is not None:
        raise ConfigError(
            f"give the frames of a skeleton strip or every, not both (got frames={frames!r}, every={every!r})"
        )
    if frames is not None:
        shown = [check_number("frames", f, 0, count - 1, integer=True) for f in frames]
    elif every is not None:
        shown = list(range(0, count, check_number("every", every, 1, integer=True)))
    else:
        shown = sorted(set(np.linspace(0, count - 1, min(count, SKELETON_STRIP_FRAMES)).round().astype(int)))
    if not 1 <= len(shown) <= SKELETON_STRIP_MAX_FRAMES:
        raise ConfigError(
            f"a skeleton strip draws 1 to {SKELETON_STRIP_MAX_FRAMES} frames, these settings "
            f"draw {len(shown)} of {count}; give fewer frames or a larger every"
        )
    return [int(f) for f in shown]


def _skeleton_box(joints_mm: np.ndarray) -> tuple[float, tuple[float, float]]:
    """Of (F, J, 3) joints: the side (mm) of the square of ground that holds the model in any
    of the frames, and the (bottom, top) of a height that holds it in all of them."""
    extent = np.nanmax(joints_mm, axis=1) - np.nanmin(joints_mm, axis=1)  # (F, 3)
    ground_span = float(np.max(extent[:, [0, 2]])) + 2 * SKELETON_MARGIN_MM
    return ground_span, (
        float(np.nanmin(joints_mm[..., 1])) - SKELETON_MARGIN_MM,
        float(np.nanmax(joints_mm[..., 1])) + SKELETON_MARGIN_MM,
    )


def _bones(joints_mm: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """(3 B, 3) the bones of (J, 3) joints as one polyline: each bone's two ends, then a NaN."""
    children = np.flatnonzero(parents >= 0)
    ends = np.stack([joints_mm[parents[children]], joints_mm[children], np.full((len(children), 3), np.nan)], axis=1)
    return ends.reshape(-1, 3)


def _draw_skeleton(ax, joints_mm: np.ndarray, parents: np.ndarray) -> tuple:
    """Draw (J, 3) joints and their bones on a 3-D axes, x and z (world) on its ground, y up;
    returns the (bones, joints) lines."""
    bones = _bones(joints_mm, parents)
    (bone_line,) = ax.plot(bones[:, 0], bones[:, 2], bones[:, 1], color="tab:blue", lw=2)
    (joint_line,) = ax.plot(joints_mm[:, 0], joints_mm[:, 2], joints_mm[:, 1], ls="", marker="o", ms=3, color="tab:red")
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
    fig = plt.figure(figsize=(SKELETON_ANIMATION_INCHES,) * 2, dpi=SKELETON_ANIMATION_DPI, layout="constrained")
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
    frames[0].save(encoded, format="GIF", save_all=True, append_images=frames[1:], duration=round(1000 / fps), loop=0)
    with atomic_writer(path, "wb") as f:
        f.write(encoded.getvalue())
