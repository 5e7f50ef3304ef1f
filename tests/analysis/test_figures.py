"""Figures (mmocap.analysis.figures): every plot fits its saved image, its legends hide no
data, frame axes have whole-number ticks; the 3-D skeleton strip and animation."""
import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PathCollection
from matplotlib.text import Text
from PIL import Image, ImageSequence

from mmocap.analysis import figures
from mmocap.body.skeleton import PARENT_INDEX
from mmocap.errors import ConfigError, DataError, MmocapWarning

LONG = "an algorithm with a very long descriptive name, hierarchical, restarted"
#: tolerance (pixels) of the containment checks, for anti-aliased edges
SLACK_PX = 1.0


def inside(box, outer) -> bool:
    return (box.x0 >= outer.x0 - SLACK_PX and box.y0 >= outer.y0 - SLACK_PX
            and box.x1 <= outer.x1 + SLACK_PX and box.y1 <= outer.y1 + SLACK_PX)


def texts_of(fig) -> list[Text]:
    """The texts that a figure draws: its own (suptitle), its axes' titles, labels and
    annotations, and its legends' entries."""
    texts = list(fig.texts)
    for ax in fig.axes:
        texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label, *ax.texts]
        if hasattr(ax, "zaxis"):
            texts.append(ax.zaxis.label)
    for legend in legends_of(fig):
        texts += legend.get_texts()
    return [t for t in texts if t.get_visible() and t.get_text()]


def legends_of(fig) -> list:
    return list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]


def data_points_px(ax) -> np.ndarray:
    """(N, 2) display coordinates of an axes' data: its lines (densely along each segment),
    scatter points, bands and boxes; those outside the axes (not drawn) left out."""
    points = []
    for line in ax.lines:
        xy = line.get_transform().transform(line.get_xydata())
        steps = np.linspace(0, 1, 16)[:, None, None]
        points.append((xy[:-1] + steps * (xy[1:] - xy[:-1])).reshape(-1, 2) if len(xy) > 1 else xy)
    for collection in ax.collections:
        if isinstance(collection, PathCollection):
            points.append(collection.get_offset_transform().transform(collection.get_offsets()))
        else:
            points += [collection.get_transform().transform(p.vertices) for p in collection.get_paths()]
    for patch in ax.patches:
        points.append(patch.get_transform().transform(patch.get_path().vertices))
    points = np.concatenate([p for p in points if len(p)]) if points else np.empty((0, 2))
    points = points[np.isfinite(points).all(axis=1)]
    box = ax.bbox
    return points[(points[:, 0] >= box.x0) & (points[:, 0] <= box.x1)
                  & (points[:, 1] >= box.y0) & (points[:, 1] <= box.y1)]


def assert_fits(fig, path):
    """The saved image is the figure's canvas; every text, legend and axes (with its tick
    labels) lies inside it; no legend covers a data point of a 2-D axes."""
    canvas = FigureCanvasAgg(fig)  # a closed figure keeps no canvas that draws
    canvas.draw()
    renderer = canvas.get_renderer()
    canvas = fig.bbox
    with Image.open(path) as image:
        assert np.abs(np.subtract(image.size, canvas.size)).max() < 1, "the image is not the canvas"
    for text in texts_of(fig):
        assert inside(text.get_window_extent(renderer), canvas), f"text {text.get_text()!r} is cut off"
    for legend in legends_of(fig):
        assert inside(legend.get_window_extent(renderer), canvas), "a legend is cut off"
    for ax in fig.axes:
        assert inside(ax.get_tightbbox(renderer), canvas), f"axes {ax.get_title()!r} is cut off"
    for legend in legends_of(fig):
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            if hasattr(ax, "zaxis"):
                continue
            points = data_points_px(ax)
            covered = ((points[:, 0] > box.x0) & (points[:, 0] < box.x1)
                       & (points[:, 1] > box.y0) & (points[:, 1] < box.y1))
            assert not covered.any(), f"the legend covers {covered.sum()} data points of {ax.get_title()!r}"


def assert_whole_frame_ticks(ax):
    low, high = sorted(ax.get_xlim())
    ticks = [t for t in ax.get_xticks() if low <= t <= high]
    assert ticks and all(float(t).is_integer() for t in ticks), ticks


def test_error_per_frame_fits_with_whole_frame_ticks(tmp_path):
    errors = np.array([40.0, 55.0, 48.0])  # three frames: matplotlib would tick every quarter
    fig = figures.plot_error_per_frame(errors, tmp_path / "e.png", "a run")
    assert_fits(fig, tmp_path / "e.png")
    assert_whole_frame_ticks(fig.axes[0])


@pytest.mark.parametrize("algorithms", [2, 12])
def test_error_curves_of_many_long_names_fit_with_whole_frame_ticks(tmp_path, algorithms):
    rng = np.random.default_rng(algorithms)
    names = [f"{LONG} {k}" for k in range(algorithms)]
    # errors at the top left, where the legend used to be
    errors = pd.DataFrame(rng.uniform(10, 100, (4, algorithms)), index=range(10, 14), columns=names)
    spread = (errors - 5, errors + 5)
    fig = figures.plot_error_curves(errors, tmp_path / "c.png", "curves", spread=spread, note="origin")
    assert_fits(fig, tmp_path / "c.png")
    assert_whole_frame_ticks(fig.axes[0])
    with Image.open(tmp_path / "c.png") as image:
        assert image.info["Description"] == "origin"


@pytest.mark.parametrize("hues", [3, 24])
def test_grouped_boxplots_of_many_long_hue_levels_fit(tmp_path, hues):
    rng = np.random.default_rng(hues)
    rows = [dict(sequence=s, pair=f"{LONG[:40]} ({h})", budget=b, kind=k, error=e)
            for s in ("S1_walking", "S2_jog") for h in range(hues) for b in (250, 1000)
            for k in ("holistic", "hierarchical") for e in rng.uniform(0, 200, 3)]
    fig = figures.plot_grouped_boxplots(pd.DataFrame(rows), tmp_path / "b.png", value="error", x="sequence",
                                        hue="pair", panel=["budget", "kind"], ylabel="error (mm)",
                                        title="boxes")
    assert_fits(fig, tmp_path / "b.png")
    assert len(fig.legends[0].get_texts()) == hues


@pytest.mark.parametrize("backends", [1, 9])
def test_pareto_front_of_many_backends_fits(tmp_path, backends):
    rng = np.random.default_rng(backends)
    table = pd.DataFrame([dict(vertices=v, backend=f"backend-{b}-{LONG[:20]}", evaluations=e,
                               seconds_per_frame=rng.uniform(0.01, 1), mean_marker_error_mm=rng.uniform(20, 90))
                          for v in (13695, 3000) for b in range(backends) for e in (250, 1000)])
    table["pareto"] = table["mean_marker_error_mm"] == table["mean_marker_error_mm"].min()
    fig = figures.plot_pareto_front(table, tmp_path / "p.png", title="front")
    assert_fits(fig, tmp_path / "p.png")


def test_frames_per_second_of_many_backends_fits(tmp_path):
    table = pd.DataFrame([dict(backend=f"{LONG[:30]} {b}", vertices=v, evaluations=e, fps=1e4 / (e * (b + 1)),
                               extrapolated=b == 0)
                          for b in range(8) for v in (13695, 3000) for e in (250, 500, 1000, 1500)])
    fig = figures.plot_frames_per_second(table, tmp_path / "f.png", title="speed")
    assert_fits(fig, tmp_path / "f.png")


def walking(frames: int) -> np.ndarray:
    """(frames, 16, 3) mm: a stick figure stepping forward (+z), its left wrist swinging."""
    rest = np.array([[0, 950, 0], [0, 1000, -26], [0, 1230, -23], [190, 1430, 0], [200, 1180, 0],
                     [210, 940, 20], [-190, 1430, 0], [-200, 1180, 0], [-210, 940, 20], [0, 1350, -8],
                     [118, 925, 0], [130, 480, 20], [135, 80, -15], [-118, 925, 0], [-130, 480, 20],
                     [-135, 80, -15]], dtype=float)
    joints = np.repeat(rest[None], frames, axis=0)
    joints[..., 2] += np.linspace(0, 1200, frames)[:, None]
    joints[:, 5, 2] += 200 * np.sin(np.linspace(0, 2 * np.pi, frames))
    return joints


def test_skeleton_strip_draws_evenly_spaced_frames_on_equal_scales(tmp_path):
    path = tmp_path / "strip.png"
    fig = figures.plot_skeleton_strip(walking(30), PARENT_INDEX, path, "S1 walking")
    assert_fits(fig, path)
    panels = figures.SKELETON_STRIP_FRAMES
    width, height = figures.SKELETON_PANEL_INCHES
    with Image.open(path) as image:
        assert image.size == (round(panels * width * figures.SKELETON_DPI), round(height * figures.SKELETON_DPI))
    assert [ax.get_title() for ax in fig.axes] == [f"frame {f}" for f in (0, 4, 8, 12, 17, 21, 25, 29)]
    scales = [np.abs(np.diff([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()], axis=1)).ravel() / ax.get_box_aspect()
              for ax in fig.axes]
    np.testing.assert_allclose(scales, scales[0][0])  # mm per unit of box: one for all axes and panels


def test_skeleton_strip_draws_every_bone_of_the_frames_asked_for(tmp_path):
    joints = walking(10)
    fig = figures.plot_skeleton_strip(joints, PARENT_INDEX, tmp_path / "s.png", "every", every=4)
    assert [ax.get_title() for ax in fig.axes] == ["frame 0", "frame 4", "frame 8"]
    bones = fig.axes[1].lines[0].get_data_3d()
    ends = np.column_stack(bones)[~np.isnan(bones[0])]  # (2 bones, 3): plot x, y, z = world x, z, y
    assert len(ends) == 2 * (len(PARENT_INDEX) - 1)
    np.testing.assert_allclose(ends[-1], joints[4, -1, [0, 2, 1]])
    fig = figures.plot_skeleton_strip(joints, PARENT_INDEX, tmp_path / "s.png", "frames", frames=[9, 2])
    assert [ax.get_title() for ax in fig.axes] == ["frame 9", "frame 2"]


@pytest.mark.parametrize("settings, match", [
    (dict(frames=[1], every=2), "not both"),
    (dict(frames=[10]), "frames must be an integer in"),
    (dict(every=0), "every must be an integer in"),
    (dict(frames=list(range(10)) * 3), "draws 1 to 24 frames"),
], ids=["frames and every", "frame past the end", "every zero", "too many frames"])
def test_skeleton_strip_settings_out_of_range_are_config_errors(tmp_path, settings, match):
    with pytest.raises(ConfigError, match=match):
        figures.plot_skeleton_strip(walking(10), PARENT_INDEX, tmp_path / "s.png", "bad", **settings)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("joints, parents, match", [
    (np.zeros((3, 16)), PARENT_INDEX, r"joints_mm must be \(frames, joints, 3\)"),
    (np.zeros((3, 16, 3)), PARENT_INDEX[:-1], "parents must hold one integer per joint"),
    (np.zeros((3, 16, 3)), np.where(PARENT_INDEX == -1, 0, PARENT_INDEX), "parents must hold"),
    (np.where(np.arange(3)[:, None, None] == 1, np.nan, np.zeros((3, 16, 3))), PARENT_INDEX,
     "frames 1 have no finite joint"),
], ids=["joints without xyz", "parents short", "root its own parent", "frame all NaN"])
def test_a_skeleton_of_the_wrong_shape_is_a_data_error(tmp_path, joints, parents, match):
    with pytest.raises(DataError, match=match):
        figures.plot_skeleton_strip(joints, parents, tmp_path / "s.png", "bad")


def test_skeleton_animation_gif_has_one_image_per_frame(tmp_path):
    path = figures.write_skeleton_animation(walking(5), PARENT_INDEX, tmp_path / "a.gif", fps=10,
                                            title="S1", progress=False)
    side = round(figures.SKELETON_ANIMATION_INCHES * figures.SKELETON_ANIMATION_DPI)
    with Image.open(path) as gif:
        frames = list(ImageSequence.Iterator(gif))
        assert len(frames) == 5 and gif.size == (side, side)
        assert gif.info["duration"] == 100 and gif.info["loop"] == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]


def test_skeleton_animation_mp4_has_one_image_per_frame(tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    path = figures.write_skeleton_animation(walking(6), PARENT_INDEX, tmp_path / "a.mp4", fps=12,
                                            progress=False)
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(path))
    assert frames == 6 and seconds == pytest.approx(0.5)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mp4"]


def test_skeleton_animation_other_formats_are_config_errors_and_fast_gifs_warned(tmp_path):
    with pytest.raises(ConfigError, match=r"a.avi: .* \.gif or \.mp4"):
        figures.write_skeleton_animation(walking(2), PARENT_INDEX, tmp_path / "a.avi", fps=10, progress=False)
    with pytest.raises(ConfigError, match="fps must be a number"):
        figures.write_skeleton_animation(walking(2), PARENT_INDEX, tmp_path / "a.gif", fps=0, progress=False)
    with pytest.warns(MmocapWarning, match="plays at most 50 frames per second"):
        figures.write_skeleton_animation(walking(2), PARENT_INDEX, tmp_path / "a.gif", fps=60, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]
