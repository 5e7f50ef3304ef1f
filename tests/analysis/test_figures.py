"""Figures (mmocap.analysis.figures): every plot fits its saved image, its legends hide no
data, frame axes have whole-number ticks. The same checks serve the run's own pictures
(tests/outputs)."""
import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PathCollection
from matplotlib.text import Text
from PIL import Image

from mmocap.analysis import figures

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
