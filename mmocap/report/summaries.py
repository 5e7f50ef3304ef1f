"""Collect the ``summary.json`` files of finished runs into one table.

``python -m mmocap.report.summaries FOLDER [--csv OUT]`` prints a Markdown table (one row
per run, best first) of every summary.json below FOLDER.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd

from mmocap.errors import DataError
from mmocap.io import write_text_atomic

COLUMNS = ["optimizer", "strategy", "dof", "evaluations_per_frame", "subject", "action", "frames",
           "mean_marker_error_mm", "median_marker_error_mm", "max_marker_error_mm",
           "seconds_per_frame", "backend"]


def collect(folder: Path) -> pd.DataFrame:
    """One row per summary.json below ``folder``, sorted by mean marker error."""
    rows = []
    for path in sorted(Path(folder).rglob("summary.json")):
        try:
            summary = json.loads(path.read_text())
        except ValueError as exc:
            raise DataError(f"{path} is not valid JSON ({exc}); that run did not finish: delete its folder "
                            "or run it again") from None
        if not isinstance(summary, dict):
            raise DataError(f"{path} is not a run summary (a JSON object)")
        rows.append({**{k: summary.get(k) for k in COLUMNS}, "run": str(path.parent)})
    if not rows:
        return pd.DataFrame(columns=COLUMNS + ["run"])
    return pd.DataFrame(rows).sort_values("mean_marker_error_mm", ignore_index=True)


def main(argv: list[str], prog: str) -> None:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--csv", type=Path, help="also write the table as CSV")
    args = parser.parse_args(argv)
    if not args.folder.is_dir():
        raise DataError(f"no such folder: {args.folder}")
    table = collect(args.folder)
    if table.empty:
        raise DataError(f"no summary.json below {args.folder}: has a sweep run into it?")
    if args.csv:
        write_text_atomic(args.csv, table.to_csv(index=False))
    print(table.drop(columns="run").to_markdown(index=False, floatfmt=".1f"))
