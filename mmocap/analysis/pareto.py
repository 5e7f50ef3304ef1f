"""Stage "Pareto analysis": the configurations no other beats on every objective (Cano Fig. 4).

Configuration a dominates b when a is no worse than b on every objective and strictly better
on at least one (Cano Sec. 6.3); here every objective is minimised (time per frame in
seconds, marker error in mm). The non-dominated configurations form the Pareto front; two
configurations with equal objectives do not dominate each other, so both stay on it.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from mmocap.analysis.statistics import finite_numbers, no_empty_cells, overflow_free_mean, require_columns
from mmocap.errors import DataError

CONFIGURATION = ["vertices", "evaluations", "backend"]
OBJECTIVES = ["seconds_per_frame", "mean_marker_error_mm"]


def non_dominated(points: np.ndarray) -> np.ndarray:
    """(n, m) objective values, all minimised -> (n,) bool, True for the Pareto front."""
    points = np.asarray(points, dtype=float)
    if points.ndim != 2:
        raise DataError(f"objective values must be an (n, m) array, got shape {points.shape}")
    no_worse = (points[:, None, :] <= points[None, :, :]).all(axis=2)  # [j, i]: j <= i everywhere
    better = (points[:, None, :] < points[None, :, :]).any(axis=2)
    return ~(no_worse & better).any(axis=0)  # type: ignore[return-value]  # (n,): numpy's stubs allow a scalar


def summarise(
    runs: pd.DataFrame, by: list[str] = CONFIGURATION, objectives: list[str] = OBJECTIVES, source: str = "runs"
) -> pd.DataFrame:
    """Mean objectives per configuration, with the run count and a ``pareto`` column.

    Args:
        runs: one row per run.
        by: the columns naming a configuration.
        objectives: the numeric columns, all minimised.
        source: the table's origin, for error messages.

    Returns:
        One row per configuration: the ``by`` columns, the mean of each objective
        (:func:`overflow_free_mean`: runs whose means are equal in exact arithmetic give equal
        means, so neither configuration dominates the other), ``runs`` (how many were
        averaged) and ``pareto`` (bool), sorted by the first objective.
        A missing column, an empty configuration cell, or an objective that is not a finite
        number is a DataError naming the column and the row.
    """
    require_columns(runs, [*by, *objectives], source)
    if runs.empty:
        raise DataError(f"{source}: no runs to compare")
    values = {column: finite_numbers(runs, column, source) for column in objectives}
    no_empty_cells(runs, by, source)  # every run needs its configuration: a groupby would drop it
    grouped = runs[by].assign(**values).groupby(by, observed=True)
    table = grouped[objectives].agg(overflow_free_mean).assign(runs=grouped.size()).reset_index()
    table["pareto"] = non_dominated(table[objectives].to_numpy())
    return table.sort_values([*objectives], kind="stable", ignore_index=True)
