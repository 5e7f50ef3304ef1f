"""Friedman test and Holm's comparisons against the best-ranked algorithm, on any long table.

``python -m mmocap.report.stats results.csv --block sequence,seed --algorithm algorithm
--value mean_marker_error_mm [--out outputs/tables/stem]`` prints the test and the table of
comparisons (rank, z, p, Holm's alpha / (k - j), Holm-adjusted p, significant) and, with
``--out``, writes it as stem.csv, stem.md and stem.tex. The method and the handling of bad
input are described in :mod:`mmocap.analysis.statistics`. Errors print one line and exit 2;
``--alpha`` outside (0, 1) and an ``--out`` that names a folder, or whose folder cannot be
written (a file in its way, a read-only file system), fail before the test runs.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import pandas as pd

from mmocap.analysis.statistics import FriedmanHolm, friedman_holm, read_table
from mmocap.analysis.tables import Format, format_p, to_markdown, write_table
from mmocap.errors import ConfigError
from mmocap.io import check_writable_folder
from mmocap.validate import check_number

COLUMN_NAMES = {
    "algorithm": "Algorithm",
    "rank": "Rank",
    "z": "z",
    "p": "p-value",
    "holm_alpha": "Holm alpha",
    "holm_p": "Holm p",
    "significant": "Significant",
}
P_FORMATS: dict[str, Format] = {"p-value": format_p, "Holm p": format_p, "Holm alpha": ".4f"}


def comparisons_table(result: FriedmanHolm) -> pd.DataFrame:
    """The comparisons with readable column names, ready for :func:`write_table`."""
    return result.comparisons.rename(columns=COLUMN_NAMES)


def parse_args(argv, prog: str = "mmocap stats"):
    """The command-line arguments of ``mmocap stats`` (see the module's docstring) as a namespace."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    parser.add_argument("table", type=Path, help="CSV or Parquet file, one row per measurement")
    parser.add_argument(
        "--block",
        default="sequence,seed",
        help="comma-separated columns that together name a block (default: %(default)s)",
    )
    parser.add_argument("--algorithm", default="algorithm", help="column naming the algorithm")
    parser.add_argument("--value", default="mean_marker_error_mm", help="numeric column compared")
    parser.add_argument(
        "--higher-is-better",
        action="store_true",
        help="rank the highest value first (default: the lowest, as for an error)",
    )
    parser.add_argument("--control", help="control algorithm (default: the best-ranked)")
    parser.add_argument("--alpha", type=float, default=0.05, help="significance level")
    parser.add_argument("--out", help="write OUT.csv, OUT.md and OUT.tex (OUT: a path without suffix)")
    return parser.parse_args(argv)


def output_stem(out: str) -> Path:
    """``--out`` as the stem of the files to write, its folder created and checked writable;
    a ConfigError if it names a folder, a WriteError naming the folder that cannot be written."""
    stem = Path(out)
    if out.endswith(("/", os.sep)) or stem.is_dir():
        raise ConfigError(
            f"--out {out} is a folder; give the stem of the files to write, e.g. --out {stem / 'friedman'}"
        )
    check_writable_folder(stem.parent)
    return stem


def run(args) -> FriedmanHolm:
    """Run the Friedman test and Holm's comparisons that ``args`` (of :func:`parse_args`) ask for:
    print the table, write it with ``--out``, and return the result."""
    alpha = check_number("--alpha", args.alpha, 0, 1, low_open=True, high_open=True)
    out = output_stem(args.out) if args.out else None
    table = read_table(args.table)
    blocks = [c.strip() for c in args.block.split(",") if c.strip()]
    result = friedman_holm(
        table,
        blocks,
        args.algorithm,
        args.value,
        higher_is_better=args.higher_is_better,
        control=args.control,
        alpha=alpha,
        source=str(args.table),
    )
    title = f"Friedman ranks of {args.value} by {args.algorithm}, Holm vs {result.control}"
    shown = comparisons_table(result)
    print(to_markdown(shown, title, result.summary(), formats=P_FORMATS))
    if out:
        paths = write_table(shown, out, title=f"{title}. {result.summary()}", source=args.table, formats=P_FORMATS)
        print("written: " + ", ".join(map(str, paths)))
    return result


def main(argv: list[str], prog: str) -> None:
    """``mmocap stats TABLE [OPTIONS]``: the Friedman test and Holm's comparisons on a table."""
    run(parse_args(argv, prog))
