"""``mmocap collect FOLDER``: the tables of a results store, ``runs.csv`` and ``frames.csv``.

The store's records and the tables' columns are those of :mod:`mmocap.analysis.results`; a
sweep writes the tables at its end (:mod:`mmocap.sweep`), and this command writes them again.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from mmocap.analysis.results import load_runs
from mmocap.io import write_text_atomic


def collect(folder) -> tuple[Path, Path]:
    """Write ``runs.csv`` and ``frames.csv`` into the store ``folder``; returns their paths."""
    folder = Path(folder)
    runs, frames = load_runs(folder)
    return (
        write_text_atomic(folder / "runs.csv", runs.to_csv(index=False)),
        write_text_atomic(folder / "frames.csv", frames.to_csv(index=False)),
    )


def main(argv: list[str], prog: str) -> None:
    """``mmocap collect FOLDER``: write runs.csv and frames.csv of a results store."""
    parser = argparse.ArgumentParser(prog=prog, description="Write runs.csv and frames.csv of a results store.")
    parser.add_argument("folder", type=Path, help="a sweep folder (holding records/)")
    runs_csv, frames_csv = collect(parser.parse_args(argv).folder)
    print(f"{runs_csv} ({len(pd.read_csv(runs_csv))} runs), {frames_csv}")
