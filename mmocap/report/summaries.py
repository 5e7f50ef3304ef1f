"""Collect the ``summary.json`` files of finished runs into one table.

``mmocap summaries FOLDER [--csv OUT]`` prints a Markdown table (one row per run, best
first) of every summary.json below FOLDER. A run without ground truth (a null mean marker
error) is listed last, with a warning naming it; a summary that
:func:`mmocap.run_folder.read_summary` refuses is an error naming the file.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import pandas as pd

from mmocap.errors import DataError, MmocapWarning
from mmocap.io import write_text_atomic
from mmocap.run_folder import SUMMARY, read_summary, summary_paths

ERRORS = ["mean_marker_error_mm", "median_marker_error_mm", "max_marker_error_mm"]
COLUMNS = [
    "optimizer",
    "strategy",
    "dof",
    "evaluations_per_frame",
    "subject",
    "action",
    "frames",
    "mean_marker_error_mm",
    "median_marker_error_mm",
    "max_marker_error_mm",
    "seconds_per_frame",
    "backend",
]


def collect(folder: Path) -> pd.DataFrame:
    """One row per run summary below ``folder``, sorted by mean marker error."""
    rows = []
    for path in summary_paths(folder):
        summary = read_summary(path.parent)
        rows.append({**{k: getattr(summary, k) for k in COLUMNS}, "run": str(path.parent)})
    if not rows:
        return pd.DataFrame(columns=COLUMNS + ["run"])
    table = pd.DataFrame(rows).astype({key: float for key in ERRORS})
    unscored = table.loc[table["mean_marker_error_mm"].isna(), "run"].tolist()
    if unscored:
        warnings.warn(
            f"{len(unscored)} run(s) without ground truth (mean_marker_error_mm null), listed "
            f"last: {', '.join(unscored[:3])}{', ...' if len(unscored) > 3 else ''}",
            MmocapWarning,
            stacklevel=2,
        )
    return table.sort_values("mean_marker_error_mm", ignore_index=True, na_position="last")


def main(argv: list[str], prog: str) -> None:
    """``mmocap summaries FOLDER [--csv OUT]``: print (and write) the table of the run summaries
    below a folder."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--csv", type=Path, help="also write the table as CSV")
    args = parser.parse_args(argv)
    if not args.folder.is_dir():
        raise DataError(f"no such folder: {args.folder}")
    table = collect(args.folder)
    if table.empty:
        raise DataError(f"no {SUMMARY} below {args.folder}: has a sweep run into it?")
    if args.csv:
        write_text_atomic(args.csv, table.to_csv(index=False))
    print(table.drop(columns="run").to_markdown(index=False, floatfmt=".1f"))
