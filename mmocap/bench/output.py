"""Where the benchmark's tables go: a CSV and a Markdown file each, titled and with the
machine they were measured on, and optionally a section each of one results page (``make
bench``'s ``docs/results/bench.md``, :mod:`mmocap.report.results_page`). Every file is
written atomically."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from mmocap.io import write_text_atomic
from mmocap.report.results_page import machine, update_page

#: the page's sections in the order they appear, by table name (others follow these)
PAGE_ORDER = (
    "table2",
    "table1",
    "roofline",
    "kernel_parts",
    "keypoints",
    "fidelity",
    "fidelity_cano",
    "fullhd",
    "fullhd_foreground",
)


def update_bench_page(page: Path, written: dict[str, str], replaced: Iterable[str]) -> None:
    """Put the sections ``written`` (Markdown, by table name) on ``make bench``'s page in
    place of those of the tables named in ``replaced`` (the tables a subcommand makes; the
    others' sections stay), in :data:`PAGE_ORDER`, under a new stamp."""
    update_page(page, "bench", None, written, replaced, PAGE_ORDER)


@dataclass
class TableWriter:
    """Writes tables as ``{prefix}{name}.csv`` and ``.md`` into ``out``, and keeps each
    one's section of a page (:func:`update_bench_page`) in ``sections``, by name."""

    out: Path
    prefix: str = ""
    sections: dict[str, str] = field(default_factory=dict)

    def path(self, name: str, suffix: str) -> Path:
        """Where the output ``name`` (a table's or a figure's) goes: ``out/{prefix}{name}{suffix}``."""
        return self.out / f"{self.prefix}{name}{suffix}"

    def write(self, df: pd.DataFrame, name: str, title: str) -> None:
        """CSV and Markdown (with a title and the machine) of ``df``, and its section."""
        table = df.to_markdown(index=False, floatfmt=".4g")
        write_text_atomic(self.path(name, ".csv"), df.to_csv(index=False))
        text = f"# {title}\n\n{machine()}\n\n{table}\n"
        write_text_atomic(self.path(name, ".md"), text)
        print(text)
        self.sections[name] = f"## {title}\n\n{table}"
