"""Stage "statistics": Friedman ranks and Holm's comparisons against a control algorithm.

The non-parametric procedure of the Yeguas paper (Sec. 5.4, Tables 4-7), as set out by
Demšar (2006) and García et al. (2010), on k algorithms measured on the same N blocks:

1. A long table (one row per measurement: block columns, an algorithm column, a value
   column) becomes an N x k matrix. Several rows for one (block, algorithm) cell, e.g. the
   seeds of a sequence when the blocks are sequences, are averaged (see below).
2. Within each block the algorithms are ranked, 1 = best (the lowest value, unless higher is
   better); tied values share the mean of the ranks they span. R_j is the average rank of
   algorithm j over the N blocks.
3. Friedman's statistic chi2_F = 12N / (k(k+1)) * (sum_j R_j^2 - k(k+1)^2 / 4), chi-square
   with k - 1 degrees of freedom, and Iman and Davenport's F_F = (N-1) chi2_F /
   (N(k-1) - chi2_F), F with k - 1 and (k-1)(N-1). As in those texts there is no tie
   correction (``scipy.stats.friedmanchisquare`` divides by one, so the two agree only on
   data without ties).
4. Each algorithm i against the control 0 (the best-ranked unless named):
   z = (R_i - R_0) / sqrt(k(k+1) / (6N)), two-sided p from the normal distribution. Holm's
   step-down procedure sorts the k-1 p-values; the j-th smallest (j = 1..k-1) is significant
   when p <= alpha / (k - j) and every smaller one was. The Holm-adjusted p-value of the j-th
   is max over l <= j of min(1, (k - l) p_(l)): significant exactly when it is <= alpha.

Bad input is a :class:`mmocap.errors.DataError` naming the source and the column: a missing
or duplicated column, a column given two roles (a block column that is also the algorithm),
a value that is not a number, NaN, empty or infinite values (a failed measurement must not
pass for a missing one), empty block or algorithm cells, fewer than three algorithms or two
blocks. A block that lacks some algorithm (a sweep still running leaves such blocks) is
dropped with an :class:`IncompleteBlocksWarning` naming it, and the test's summary line says
how many were.

A cell's mean is its exact mean (every finite float is a fraction with a power-of-two
denominator, summed and divided with nothing rounded away) rounded once to the nearest
float, :func:`overflow_free_mean`. Cells whose means are equal in exact arithmetic therefore
tie, whatever their values' order and count ([6, 6, 4] and [6, 5, 5] are both 16/3, where
the sums 6/3 + 6/3 + 4/3 and 6/3 + 5/3 + 5/3 differ in the last bit); the ranks are those of
the means as printed, so means that differ by less than the float's resolution tie as their
printed values do; and values near the float limit (1e308) rank as the same values scaled
down would.
"""

from __future__ import annotations

import csv
import itertools
import warnings
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from mmocap.errors import DataError, MmocapWarning
from mmocap.validate import is_integer

MIN_ALGORITHMS = 3
MIN_BLOCKS = 2


class IncompleteBlocksWarning(MmocapWarning):
    """Blocks without a value for every algorithm were left out of the test."""


def block_matrix(
    table: pd.DataFrame, block: list[str] | str, algorithm: str, value: str, source: str = "table"
) -> tuple[pd.DataFrame, list[str]]:
    """Long table -> (N blocks, k algorithms) matrix of mean values (:func:`overflow_free_mean`)
    over the complete blocks, and the names of the incomplete blocks left out (each warned about).

    Args:
        table: one row per measurement.
        block: the column or columns whose values together name a block.
        algorithm: the column naming the algorithm.
        value: the numeric column compared (e.g. an error in mm).
        source: the table's origin (a file name) for error messages.
    """
    block = [block] if isinstance(block, str) else list(block)
    if not block:
        raise DataError(f"{source}: no block column given")
    require_columns(table, [*block, algorithm, value], source)
    if table.empty:
        raise DataError(f"{source}: the table has a header but no data rows")
    roles = [*block, algorithm, value]
    repeated = sorted({c for c in roles if roles.count(c) > 1})
    if repeated:
        raise DataError(
            f"{source}: column {', '.join(map(repr, repeated))} is given more than one role "
            f"(blocks {', '.join(block)}, algorithm {algorithm!r}, value {value!r}); "
            "give each role its own column"
        )
    values = finite_numbers(table, value, source)
    no_empty_cells(table, [*block, algorithm], source)
    # names as text, so that an algorithm called 2 is asked for as --control 2
    long = table[[*block, algorithm]].assign(**{algorithm: table[algorithm].astype(str)}, _value=values)
    matrix = long.pivot_table(
        index=block, columns=algorithm, values="_value", aggfunc=overflow_free_mean, observed=True
    )
    matrix.columns.name = algorithm
    if matrix.shape[1] < MIN_ALGORITHMS:
        raise DataError(
            f"{source}: the Friedman test needs at least {MIN_ALGORITHMS} values of "
            f"{algorithm!r}, got {matrix.shape[1]}: {', '.join(map(str, matrix.columns))}"
        )
    incomplete = matrix.isna().any(axis=1)
    dropped = [_block_name(name) for name in matrix.index[incomplete]]
    if incomplete.any():
        lacking = [
            f"{_block_name(name)} (no {', '.join(map(str, row.index[row.isna()]))})"
            for name, row in matrix[incomplete].iterrows()
        ]
        warnings.warn(
            f"{source}: {len(lacking)} block(s) of {', '.join(block)} without every "
            f"{algorithm} left out: {'; '.join(lacking)}",
            IncompleteBlocksWarning,
            stacklevel=2,
        )
        matrix = matrix[~incomplete]
    if len(matrix) < MIN_BLOCKS:
        raise DataError(
            f"{source}: the Friedman test needs at least {MIN_BLOCKS} blocks "
            f"({', '.join(block)}) with a value for every {algorithm}, got {len(matrix)}"
        )
    return matrix, dropped


def overflow_free_mean(values) -> float:
    """The mean of ``values`` (n,) correctly rounded: the exact mean (the values summed and
    divided in exact arithmetic) rounded once to the nearest float. It stays finite for finite
    values near the float limit (1e308), where the sum of the values would not, and values
    whose means are equal in exact arithmetic give the same float, whatever their order and
    count. NaN or infinite values, or none, give what ``numpy.mean`` gives (NaN, or the
    infinity)."""
    values = np.asarray(values, dtype=float)
    if not len(values) or not np.isfinite(values).all():
        return float(np.mean(values))
    total = 0  # in units of 2**-1074, the smallest subnormal: every finite float is a whole number of them
    for value in values.tolist():
        numerator, denominator = value.as_integer_ratio()  # denominator: 2**j, j <= 1074
        total += numerator << (1075 - denominator.bit_length())
    return total / (len(values) << 1074)  # Python divides integers with one correct rounding


def require_columns(table: pd.DataFrame, columns: list[str], source: str) -> None:
    """DataError naming the columns of ``columns`` that ``table`` lacks, and those it has."""
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise DataError(
            f"{source}: missing column(s) {', '.join(map(repr, missing))}; "
            f"columns are {', '.join(map(str, table.columns))}"
        )


def data_row(table: pd.DataFrame, position: int) -> str:
    """Where row ``position`` of ``table`` is in its file: ``data row N`` (1 = the first row
    below the header), from its index label, which filtering keeps (a table as
    :func:`read_table` gives it has the index 0, 1, ...)."""
    label = table.index[position]
    return f"data row {label + 1}" if is_integer(label) else f"row {label!r}"


def finite_numbers(table: pd.DataFrame, column: str, source: str, *, missing_ok: bool = False) -> np.ndarray:
    """The column as floats (n,); a DataError names the first text cell, and the first NaN
    (an empty cell reads as NaN) or infinite one. ``missing_ok`` lets NaN through (values
    that may be missing, such as the marker error of a frame without ground truth)."""
    values = pd.to_numeric(table[column], errors="coerce").to_numpy(dtype=float)
    text = np.isnan(values) & table[column].notna().to_numpy()
    if text.any():
        row = text.nonzero()[0][0]
        raise DataError(
            f"{source}: column {column!r} holds {int(text.sum())} value(s) that are not "
            f"numbers, the first {table[column].iloc[row]!r} in {data_row(table, row)}"
        )
    broken = np.isinf(values) if missing_ok else ~np.isfinite(values)
    if broken.any():
        row = broken.nonzero()[0][0]
        kind = "infinite" if missing_ok else "NaN or infinite"
        raise DataError(
            f"{source}: column {column!r} holds {int(broken.sum())} {kind} value(s) (an empty "
            f"cell is NaN), the first in {data_row(table, row)}; remove those rows or "
            f"re-run their measurements"
        )
    return values


def no_empty_cells(table: pd.DataFrame, columns: list[str], source: str) -> None:
    """A DataError naming the first of ``columns`` with empty cells, how many and the first
    row: a row without its block, algorithm or configuration cannot be placed (a groupby
    would drop it silently)."""
    for column in columns:
        empty = table[column].isna().to_numpy()
        if empty.any():
            raise DataError(
                f"{source}: column {column!r} has {int(empty.sum())} empty cell(s), the first "
                f"in {data_row(table, empty.nonzero()[0][0])}; fill them in or remove those rows"
            )


def whole_numbers(table: pd.DataFrame, column: str, source: str) -> np.ndarray:
    """The column as int64 (n,); a DataError names the first cell that is not a whole number
    (text, a fraction, empty, NaN or infinite)."""
    values = pd.to_numeric(table[column], errors="coerce").to_numpy(dtype=float)
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(values) | (values != np.round(values))
    if bad.any():
        row = bad.nonzero()[0][0]
        cell = table[column].iloc[row]
        shown = "an empty cell" if pd.isna(cell) else repr(cell)
        raise DataError(
            f"{source}: column {column!r} must hold whole numbers; {int(bad.sum())} cell(s) do "
            f"not, the first {shown} in {data_row(table, row)}"
        )
    return values.astype(np.int64)


def _block_name(name) -> str:
    return "/".join(map(str, name)) if isinstance(name, tuple) else str(name)


def block_ranks(matrix: pd.DataFrame, higher_is_better: bool = False) -> pd.DataFrame:
    """(N, k) values -> (N, k) ranks within each block, 1 = best, ties at their mid-rank."""
    oriented = -matrix if higher_is_better else matrix
    return oriented.rank(axis=1, method="average")


def friedman_statistic(average_ranks: np.ndarray, n_blocks: int) -> tuple[float, float, float, float]:
    """Average ranks (k,) over N blocks -> (chi2_F, its p, Iman-Davenport F_F, its p).

    Computed in exact arithmetic from the ranks as given, so that blocks that all rank the
    algorithms alike (chi2_F = N(k-1) exactly, F_F unbounded) are told from a large F_F."""
    r = [Fraction(rank) for rank in np.asarray(average_ranks, dtype=float).tolist()]
    k, n = len(r), n_blocks
    spread = sum(x * x for x in r) - Fraction(k * (k + 1) ** 2, 4)
    chi2 = max(Fraction(12 * n, k * (k + 1)) * spread, Fraction(0))  # below 0 only for ranks no blocks give
    p = float(stats.chi2.sf(float(chi2), k - 1))
    denominator = n * (k - 1) - chi2
    if denominator > 0:
        f = float((n - 1) * chi2 / denominator)
        p_f = float(stats.f.sf(f, k - 1, (k - 1) * (n - 1)))
    else:  # every block ranks the algorithms alike: the F statistic is unbounded
        f, p_f = np.inf, 0.0
    return float(chi2), p, f, p_f


def holm_versus_control(
    average_ranks: pd.Series, n_blocks: int, control: str | None = None, alpha: float = 0.05
) -> pd.DataFrame:
    """Post-hoc comparisons of every algorithm with the control, Holm's step-down procedure.

    Args:
        average_ranks: average Friedman rank per algorithm (index: algorithm names).
        n_blocks: N, the number of blocks the ranks were averaged over.
        control: the control algorithm; None = the best-ranked (the first on ties).
        alpha: the family-wise significance level.

    Returns:
        One row per algorithm, sorted by rank with the control first: algorithm, rank,
        z, p (unadjusted, two-sided), holm_alpha (alpha / (k - j) for the j-th smallest p),
        holm_p (adjusted) and significant (bool); the control's comparison fields are NaN
        (significant False).
    """
    if not 0 < alpha < 1:
        raise DataError(f"alpha must be in (0, 1), got {alpha}")
    ranks = average_ranks.astype(float).sort_values(kind="stable")
    k = len(ranks)
    if control is None:
        control = ranks.index[0]
    else:  # matched as text: names read from a file are numbers when they look like them
        named = [name for name in ranks.index if str(name) == str(control)]
        if not named:
            raise DataError(f"control algorithm {str(control)!r} not among {', '.join(map(str, ranks.index))}")
        control = named[0]
    se = np.sqrt(k * (k + 1) / (6.0 * n_blocks))
    others = ranks.drop(control)
    z = (others - ranks[control]) / se
    p = pd.Series(2.0 * stats.norm.sf(np.abs(z.to_numpy())), index=others.index)
    order = p.sort_values(kind="stable").index
    steps = np.arange(1, k)  # j = 1 .. k-1 over the sorted p-values
    holm_alpha = pd.Series(alpha / (k - steps), index=order)
    adjusted = pd.Series(np.maximum.accumulate(np.minimum(1.0, (k - steps) * p[order].to_numpy())), index=order)
    passed = np.logical_and.accumulate(p[order].to_numpy() <= holm_alpha.to_numpy())
    significant = pd.Series(passed, index=order)
    table = pd.DataFrame(
        {"rank": ranks, "z": z, "p": p, "holm_alpha": holm_alpha, "holm_p": adjusted, "significant": significant}
    )
    table["significant"] = table["significant"].fillna(False).astype(bool)
    table = table.loc[[control, *others.index]]
    return table.rename_axis("algorithm").reset_index()


@dataclass(frozen=True)
class FriedmanHolm:
    """The outcome of :func:`friedman_holm`.

    ``comparisons`` is the table of :func:`holm_versus_control`; ``ranks`` the (N, k) ranks
    per block; ``blocks`` the block columns and ``dropped`` the incomplete blocks left out.
    """

    comparisons: pd.DataFrame
    ranks: pd.DataFrame
    n_blocks: int
    statistic: float
    p_value: float
    iman_davenport: float
    iman_davenport_p: float
    alpha: float
    blocks: list[str] = field(default_factory=list)
    dropped: list[str] = field(default_factory=list)

    @property
    def n_algorithms(self) -> int:
        """k, the number of algorithms compared."""
        return self.ranks.shape[1]

    @property
    def control(self) -> str:
        """The control algorithm the others are compared with (the first row of ``comparisons``)."""
        return self.comparisons["algorithm"].iloc[0]

    def summary(self) -> str:
        """One line: k, N, the Friedman and Iman-Davenport statistics and p-values."""
        k, n = self.n_algorithms, self.n_blocks
        return (
            f"Friedman test, {k} algorithms on {n} blocks ({', '.join(self.blocks)}): "
            f"chi2_F = {self.statistic:.3f} ({k - 1} d.o.f.), p = {self.p_value:.3g}; "
            f"Iman-Davenport F_F = {self.iman_davenport:.3f} ({k - 1}, {(k - 1) * (n - 1)} d.o.f.), "
            f"p = {self.iman_davenport_p:.3g}; Holm vs control {self.control} at alpha = {self.alpha:g}"
            + (f"; {len(self.dropped)} incomplete block(s) left out" if self.dropped else "")
        )


def friedman_holm(
    table: pd.DataFrame,
    block: list[str] | str,
    algorithm: str,
    value: str,
    *,
    higher_is_better: bool = False,
    control: str | None = None,
    alpha: float = 0.05,
    source: str = "table",
) -> FriedmanHolm:
    """Friedman test and Holm's comparisons against the control on a long table.

    See :func:`block_matrix` for the arguments shared with it; ``higher_is_better`` ranks the
    highest value first (e.g. accuracy), ``control`` and ``alpha`` go to
    :func:`holm_versus_control`.
    """
    block = [block] if isinstance(block, str) else list(block)
    matrix, dropped = block_matrix(table, block, algorithm, value, source)
    ranks = block_ranks(matrix, higher_is_better)
    average = ranks.mean(axis=0)
    chi2, p, f, p_f = friedman_statistic(average.to_numpy(), len(ranks))
    comparisons = holm_versus_control(average, len(ranks), control, alpha)
    return FriedmanHolm(
        comparisons=comparisons,
        ranks=ranks,
        n_blocks=len(ranks),
        statistic=chi2,
        p_value=p,
        iman_davenport=f,
        iman_davenport_p=p_f,
        alpha=alpha,
        blocks=block,
        dropped=dropped,
    )


def read_table(path: str | Path) -> pd.DataFrame:
    """A results table from CSV (leading '# ...' lines skipped) or Parquet (needs pyarrow), its
    index 0, 1, ... (data row N is label N - 1). A DataError names the path when it is missing,
    a folder, empty, binary, ragged or has a column name twice (pandas would rename the second
    copy, and a lookup by name would silently use the first)."""
    path = Path(path)
    if path.is_dir():
        raise DataError(f"{path} is a folder; give the table file (CSV or Parquet) in it")
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    if path.stat().st_size == 0:
        raise DataError(f"{path} is empty; a table has a header line, then one row per measurement")
    try:
        if path.suffix.lower() in (".parquet", ".pq"):
            return pd.read_parquet(path)
        with open(path, "rb") as f:
            if b"\0" in f.read(1 << 16):
                raise DataError(f"{path}: not a readable table: it holds binary data (NUL bytes), not CSV text")
        with open(path) as f:
            comments = sum(1 for _ in iter(lambda: f.readline().startswith("#"), False))
        with open(path, newline="") as f:
            header = next(itertools.islice(csv.reader(f), comments, None), [])
        repeated = sorted({str(c) for c in header if header.count(c) > 1})
        if repeated:
            raise DataError(
                f"{path}: column name(s) {', '.join(map(repr, repeated))} appear more than once "
                "in the header; rename them so that each column has its own name"
            )
        return pd.read_csv(path, skiprows=comments)
    except ImportError as err:
        raise DataError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow): {err}") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError) as err:
        raise DataError(f"{path}: not a readable table: {err}") from None
