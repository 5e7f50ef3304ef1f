"""Figures (mmocap.analysis.figures): every plot fits its saved image, its legends hide no
data, frame axes have whole-number ticks. The same checks serve the run's own pictures
(tests/writers)."""

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from mmocap.analysis import figures
from tests.helpers import assert_fits, assert_whole_frame_ticks

LONG = "an algorithm with a very long descriptive name, hierarchical, restarted"


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
    rows = [
        dict(sequence=s, pair=f"{LONG[:40]} ({h})", budget=b, kind=k, error=e)
        for s in ("S1_walking", "S2_jog")
        for h in range(hues)
        for b in (250, 1000)
        for k in ("holistic", "hierarchical")
        for e in rng.uniform(0, 200, 3)
    ]
    fig = figures.plot_grouped_boxplots(
        pd.DataFrame(rows),
        tmp_path / "b.png",
        value="error",
        x="sequence",
        hue="pair",
        panel=["budget", "kind"],
        ylabel="error (mm)",
        title="boxes",
    )
    assert_fits(fig, tmp_path / "b.png")
    assert len(fig.legends[0].get_texts()) == hues


@pytest.mark.parametrize("backends", [1, 9])
def test_pareto_front_of_many_backends_fits(tmp_path, backends):
    rng = np.random.default_rng(backends)
    table = pd.DataFrame(
        [
            dict(
                vertices=v,
                backend=f"backend-{b}-{LONG[:20]}",
                evaluations=e,
                seconds_per_frame=rng.uniform(0.01, 1),
                mean_marker_error_mm=rng.uniform(20, 90),
            )
            for v in (13695, 3000)
            for b in range(backends)
            for e in (250, 1000)
        ]
    )
    table["pareto"] = table["mean_marker_error_mm"] == table["mean_marker_error_mm"].min()
    fig = figures.plot_pareto_front(table, tmp_path / "p.png", title="front")
    assert_fits(fig, tmp_path / "p.png")


def test_frames_per_second_of_many_backends_fits(tmp_path):
    table = pd.DataFrame(
        [
            dict(backend=f"{LONG[:30]} {b}", vertices=v, evaluations=e, fps=1e4 / (e * (b + 1)), extrapolated=b == 0)
            for b in range(8)
            for v in (13695, 3000)
            for e in (250, 500, 1000, 1500)
        ]
    )
    fig = figures.plot_frames_per_second(table, tmp_path / "f.png", title="speed")
    assert_fits(fig, tmp_path / "f.png")
