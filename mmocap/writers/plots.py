"""Plots of a tracking run: its marker error per frame (``error_per_frame.png``), drawn by
the rules of :mod:`mmocap.analysis.figures`."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from mmocap.analysis.figures import legend_below, save_figure  # noqa: E402


def plot_error_per_frame(errors_mm: np.ndarray, path: Path, title: str) -> Figure:
    """Line plot of the marker error (mm, shape (frames,)) per frame with its mean; returns the
    saved (closed) figure."""
    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=110, layout="constrained")
    ax.plot(np.arange(len(errors_mm)), errors_mm, lw=1.4, label="marker error")
    ax.axhline(np.nanmean(errors_mm), color="tab:red", ls="--", lw=1, label=f"mean {np.nanmean(errors_mm):.1f} mm")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("frame")
    ax.set_ylabel("error (mm)")
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    legend_below(fig, *ax.get_legend_handles_labels())
    return save_figure(fig, path, None)
