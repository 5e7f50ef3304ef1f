"""Write one table as CSV, Markdown and LaTeX, each with a provenance line.

``write_table(df, "outputs/tables/table4", title=..., source=...)`` writes ``table4.csv``,
``table4.md`` and ``table4.tex``, each to a temporary file renamed into place, so that a
reader never sees half a table. The provenance line names the versions of mmocap and the
numerical packages, the git commit of the source tree (with ``+dirty`` when it has
uncommitted changes), the date (UTC) and the source:

- CSV: a first line ``# <provenance>`` (read back with ``pd.read_csv(path, comment="#")``);
- Markdown: the title as a heading, then the provenance in italics;
- LaTeX: ``% <provenance>``, then a ``table`` float with a booktabs ``tabular``, every cell
  escaped.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from mmocap.io import write_text_atomic
from mmocap.provenance import line as provenance

Format = str | Callable[[float], str]
LATEX_SPECIALS = {
    "\\": r"\textbackslash{}",
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\textasciicircum{}",
}


def format_cell(value, fmt: Format = ".3f") -> str:
    """A cell as text: floats with ``fmt`` (a format spec or a function; '' for NaN), booleans
    as yes/no, everything else with str()."""
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        if np.isnan(value):
            return ""
        return fmt(float(value)) if callable(fmt) else format(value, fmt)
    return "" if value is None or value is pd.NA else str(value)


def format_p(p: float) -> str:
    """A p-value as the Yeguas tables print it: 0.043, or 7.57E-04 below 0.001."""
    return f"{p:.3f}" if p >= 1e-3 else f"{p:.2E}"


def _cells(df: pd.DataFrame, floatfmt: Format, formats: dict[str, Format] | None) -> pd.DataFrame:
    formats = formats or {}
    return pd.DataFrame(
        {c: [format_cell(v, formats.get(c, floatfmt)) for v in df[c]] for c in df.columns}, columns=df.columns
    )


def latex_escape(text: str) -> str:
    """``text`` with LaTeX's special characters escaped."""
    return "".join(LATEX_SPECIALS.get(ch, ch) for ch in text)


def to_markdown(
    df: pd.DataFrame, title: str, note: str, floatfmt: Format = ".3f", formats: dict[str, Format] | None = None
) -> str:
    """Markdown: '# title', the note in italics, the table (tabulate's pipe format)."""
    cells = _cells(df, floatfmt, formats)
    cells = cells.map(lambda text: text.replace("|", "\\|"))
    body = cells.to_markdown(index=False, disable_numparse=True, colalign=[_align(df[c]) for c in df.columns])
    return f"# {title}\n\n_{note}_\n\n{body}\n"


def to_latex(
    df: pd.DataFrame, title: str, note: str, floatfmt: Format = ".3f", formats: dict[str, Format] | None = None
) -> str:
    """LaTeX: '% note', then a table float (caption = title) with a booktabs tabular."""
    spec = "".join("r" if _align(df[c]) == "right" else "l" for c in df.columns)
    lines = [
        f"% {note}",
        r"\begin{table}[htbp]",
        r"\centering",
        rf"\caption{{{latex_escape(title)}}}",
        rf"\begin{{tabular}}{{{spec}}}",
        r"\toprule",
        " & ".join(latex_escape(str(c)) for c in df.columns) + r" \\",
        r"\midrule",
    ]
    for row in _cells(df, floatfmt, formats).itertuples(index=False):
        lines.append(" & ".join(latex_escape(v) for v in row) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"


def _align(column: pd.Series) -> str:
    numeric = pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column)
    return "right" if numeric else "left"


def write_csv(df: pd.DataFrame, path: str | Path, source: str | Path | None = None) -> Path:
    """``df`` as CSV under a '# <provenance>' line, written atomically; returns the path."""
    path = Path(path)
    write_text_atomic(path, f"# {provenance(source)}\n" + df.to_csv(index=False))
    return path


def write_table(
    df: pd.DataFrame,
    stem: str | Path,
    *,
    title: str,
    source: str | Path | None = None,
    floatfmt: Format = ".3f",
    formats: dict[str, Format] | None = None,
) -> list[Path]:
    """Write ``df`` to ``stem``.csv, .md and .tex (see the module docstring); returns the paths.

    Floats are written in full in the CSV; in Markdown and LaTeX with ``formats[column]`` or
    else ``floatfmt`` (a format spec, or a function of the float returning the text).
    """
    stem = Path(stem)
    note = provenance(source)
    paths = [stem.with_name(stem.name + ext) for ext in (".csv", ".md", ".tex")]
    write_text_atomic(paths[0], f"# {note}\n" + df.to_csv(index=False))
    write_text_atomic(paths[1], to_markdown(df, title, note, floatfmt, formats))
    write_text_atomic(paths[2], to_latex(df, title, note, floatfmt, formats))
    return paths
