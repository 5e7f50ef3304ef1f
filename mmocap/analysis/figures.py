"""Figures of a sweep (error box plots, error curves of several algorithms, time-vs-error
Pareto front) and of the evaluator benchmark (frames per second); the pictures of one run are
in :mod:`mmocap.writers`, drawn by the same rules.

Every ``plot_*`` function saves its figure (:func:`save_figure`) and returns it, closed: the
saved image is the whole canvas (constrained layout, no cropping), legends lie outside the
axes, below them (:func:`legend_below`), so that they hide no data, and the figure grows to
hold them.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.legend import Legend  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from mmocap.io import atomic_writer  # noqa: E402

#: magnitude above which a value is plotted in units of a power of ten (:func:`_axis_units`)
PLOTTABLE_MAGNITUDE = 1e300
#: room (inches) kept free at each side of a legend below the axes
LEGEND_MARGIN_INCHES = 0.1


def plot_error_curves(
    errors_mm: pd.DataFrame,
    path: Path,
    title: str,
    spread: tuple[pd.DataFrame, pd.DataFrame] | None = None,
    note: str | None = None,
) -> Figure:
    """Marker error (mm) per frame of several algorithms (Yeguas Fig. 10); returns the saved
    (closed) figure.

    Args:
        errors_mm: (frames, algorithms) errors, index = frame number, one column per line.
        path: the image to write (``.png``).
        title: drawn above the axes.
        spread: optional (low, high) frames of the same shape, drawn as a band per line.
        note: provenance, stored as the PNG's Description.
    """
    fig, ax = plt.subplots(figsize=(9, 3.8), dpi=110, layout="constrained")
    for name in errors_mm.columns:
        (line,) = ax.plot(
            errors_mm.index, errors_mm[name], lw=1.4, label=f"{name} (mean {errors_mm[name].mean():.1f} mm)"
        )
        if spread is not None:
            ax.fill_between(errors_mm.index, spread[0][name], spread[1][name], color=line.get_color(), alpha=0.15, lw=0)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("frame")
    ax.set_ylabel("marker error (mm)")
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    legend_below(fig, *ax.get_legend_handles_labels())
    return save_figure(fig, path, note)


def plot_grouped_boxplots(
    data: pd.DataFrame,
    path: Path,
    *,
    value: str,
    x: str,
    hue: str,
    panel: list[str],
    ylabel: str,
    title: str,
    note: str | None = None,
) -> Figure:
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
    fig, axes = plt.subplots(
        len(panels),
        1,
        squeeze=False,
        sharey=True,
        dpi=100,
        layout="constrained",
        figsize=(min(24.0, max(7.0, 0.22 * len(xs) * widest + 1.5)), 2.6 * len(panels) + 0.6),
    )
    for ax, (key, panel_data) in zip(axes[:, 0], panels):
        present = [h for h in hues if (panel_data[hue] == h).any()]
        width = 0.8 / len(present)
        for h, name in enumerate(present):
            groups = [panel_data.loc[(panel_data[x] == v) & (panel_data[hue] == name), value].to_numpy() for v in xs]
            positions = [k - 0.4 + width * (h + 0.5) for k, g in enumerate(groups) if len(g)]
            ax.boxplot(
                [g for g in groups if len(g)],
                positions=positions,
                widths=width * 0.85,
                whis=(0, 100),
                patch_artist=True,
                manage_ticks=False,
                boxprops=dict(facecolor=colours[name], lw=0.8),
                medianprops=dict(color="black", lw=1),
                whiskerprops=dict(lw=0.8),
                capprops=dict(lw=0.8),
            )
        ax.set_xticks(range(len(xs)), [str(v) for v in xs])
        ax.set_xlim(-0.5, len(xs) - 0.5)
        ax.set_title(", ".join(map(str, key if isinstance(key, tuple) else (key,))), fontsize=10)
        ax.set_ylabel(ylabel)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(title)
    legend_below(
        fig, [plt.Rectangle((0, 0), 1, 1, facecolor=colours[h]) for h in hues], [str(h) for h in hues], fontsize=9
    )
    return save_figure(fig, path, note)


def plot_pareto_front(
    table: pd.DataFrame,
    path: Path,
    *,
    title: str,
    note: str | None = None,
    x: str = "seconds_per_frame",
    y: str = "mean_marker_error_mm",
    colour: str = "backend",
) -> Figure:
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
        ax.scatter(
            getattr(row, x),
            getattr(row, y),
            color=colours[getattr(row, colour)],
            marker=markers[row.vertices],
            s=70 if row.pareto else 35,
            edgecolors="black" if row.pareto else "none",
            zorder=2,
        )
        ax.annotate(
            f"{row.evaluations}",
            (getattr(row, x), getattr(row, y)),
            fontsize=7,
            xytext=(4, 3),
            textcoords="offset points",
        )
    handles = [plt.Line2D([], [], color="0.3", ls="--", label="Pareto front")]
    handles += [plt.Line2D([], [], ls="", marker="o", color=colours[b], label=f"{colour} {b}") for b in backends]
    handles += [plt.Line2D([], [], ls="", marker=markers[v], color="0.5", label=f"{v} vertices") for v in meshes]
    if table[x].max() > 20 * table[x].min() > 0:
        ax.set_xscale("log")
    ax.set_xlabel(f"time per frame (s){x_unit}")
    ax.set_ylabel(f"mean marker error (mm){y_unit}")
    ax.set_title(f"{title}\n(numbers: evaluations per frame; outlined: non-dominated)", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    legend_below(fig, handles, [h.get_label() for h in handles])
    return save_figure(fig, path, note)


def _axis_units(values: pd.Series) -> tuple[float, str]:
    """The factor to divide ``values`` by before plotting them, and the axis label's note of it:
    1 and '' unless they exceed :data:`PLOTTABLE_MAGNITUDE`, where matplotlib's tick arithmetic
    overflows; then the power of ten of the largest, e.g. 1e307 and ' (x 1e307)'."""
    largest = float(np.abs(values).max())
    if not largest > PLOTTABLE_MAGNITUDE:
        return 1.0, ""
    exponent = int(np.floor(np.log10(largest)))
    return 10.0**exponent, f" (x 1e{exponent})"


def plot_frames_per_second(table: pd.DataFrame, path: Path, *, title: str, note: str | None = None) -> Figure:
    """Frames per second against evaluations per frame (Cano Fig. 3), log-log: one colour per
    ``backend``, one marker per ``vertices``; rows with ``extrapolated`` drawn dashed. Returns
    the saved (closed) figure."""
    backends, meshes = list(dict.fromkeys(table["backend"])), sorted(table["vertices"].unique())
    colours = dict(zip(backends, plt.get_cmap("tab10")(np.arange(len(backends)) % 10)))
    markers = dict(zip(meshes, "os^Dvp*hX"))
    fig, ax = plt.subplots(figsize=(9.5, 5), dpi=110, layout="constrained")
    for (backend, vertices), rows in table.groupby(["backend", "vertices"], sort=False):
        rows = rows.sort_values("evaluations")
        ax.plot(
            rows["evaluations"],
            rows["fps"],
            color=colours[backend],
            marker=markers[vertices],
            ls="--" if rows["extrapolated"].any() else "-",
            lw=1.3,
            ms=6,
        )
    handles = [plt.Line2D([], [], color=colours[b], label=b) for b in backends]
    handles += [plt.Line2D([], [], ls="", marker=markers[v], color="0.5", label=f"{v} vertices") for v in meshes]
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
    legend_below(fig, handles, [h.get_label() for h in handles])
    return save_figure(fig, path, note)


def legend_below(fig: Figure, handles, labels, fontsize: float = 8) -> Legend:
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
    legend = fig.legend(handles, labels, loc="outside lower center", fontsize=fontsize, ncols=-(-len(labels) // rows))
    fig.set_figheight(fig.get_figheight() + legend.get_window_extent(renderer).height / fig.dpi)
    return legend


def _levels(column: pd.Series) -> list:
    """The distinct values of a column: in category order if categorical, else sorted."""
    if isinstance(column.dtype, pd.CategoricalDtype):
        return [c for c in column.cat.categories if (column == c).any()]
    return sorted(column.unique())


def save_figure(fig: Figure, path: Path, note: str | None) -> Figure:
    """Write ``fig`` (the whole canvas) atomically in the format of ``path``'s suffix
    (:func:`mmocap.io.atomic_writer`: a WriteError naming it if it cannot be written), ``note``
    as its Description; close it and return it."""
    path = Path(path)
    try:
        with atomic_writer(path, "wb") as f:
            fig.savefig(f, format=path.suffix.lstrip(".") or None, metadata={"Description": note} if note else None)
    finally:
        plt.close(fig)
    return fig
