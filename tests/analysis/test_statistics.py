"""Friedman ranks, Iman-Davenport and Holm against a control, checked against published
worked examples (Demšar 2006; the Yeguas paper's Tables 4 and 6; Cano Table 3), scipy, and
hand-made cases; against ``scipy.stats.rankdata`` and the formulas on generated tables
(Hypothesis); then bad input and the command line."""

import itertools
import math
import subprocess
import sys
import warnings
from fractions import Fraction

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from mmocap.analysis.statistics import (
    IncompleteBlocksWarning,
    block_ranks,
    finite_numbers,
    friedman_holm,
    friedman_statistic,
    holm_versus_control,
    no_empty_cells,
    overflow_free_mean,
    read_table,
    whole_numbers,
)
from mmocap.errors import DataError, MmocapWarning

# Demšar (2006), JMLR 7, Table 6: AUC of four C4.5 variants on fourteen UCI data sets.
DEMSAR_NAMES = ["C4.5", "C4.5+m", "C4.5+cf", "C4.5+m+cf"]
DEMSAR_AUC = [
    [0.763, 0.768, 0.771, 0.798],
    [0.599, 0.591, 0.590, 0.569],
    [0.954, 0.971, 0.968, 0.967],
    [0.628, 0.661, 0.654, 0.657],
    [0.882, 0.888, 0.886, 0.898],
    [0.936, 0.931, 0.916, 0.931],
    [0.661, 0.668, 0.609, 0.685],
    [0.583, 0.583, 0.563, 0.625],
    [0.775, 0.838, 0.866, 0.875],
    [1.000, 1.000, 1.000, 1.000],
    [0.940, 0.962, 0.965, 0.962],
    [0.619, 0.666, 0.614, 0.669],
    # voting: the paper ranks its two 0.975 as 2 (C4.5+cf) and 3 (C4.5+m+cf), so the
    # unrounded AUCs differed; 0.9751 restores that order. The other ties are the paper's.
    [0.972, 0.981, 0.9751, 0.975],
    [0.957, 0.978, 0.946, 0.970],
]


def long_table(matrix, names, block="block", algorithm="algorithm", value="value"):
    return pd.DataFrame(
        [(i, name, v) for i, row in enumerate(matrix) for name, v in zip(names, row)], columns=[block, algorithm, value]
    )


@pytest.fixture
def demsar():
    return long_table(DEMSAR_AUC, DEMSAR_NAMES, "dataset", "classifier", "auc")


def test_demsar_ranks_friedman_and_iman_davenport(demsar):
    result = friedman_holm(demsar, "dataset", "classifier", "auc", higher_is_better=True)
    ranks = result.comparisons.set_index("algorithm")["rank"]
    # the paper: 3.143, 2.000, 2.893, 1.964; chi2_F = 9.28; F_F = 3.69 with (3, 39) d.o.f.
    assert ranks[DEMSAR_NAMES].to_numpy() == pytest.approx([3.143, 2.000, 2.893, 1.964], abs=5e-4)
    assert result.statistic == pytest.approx(9.28, abs=5e-3)
    assert result.iman_davenport == pytest.approx(3.69, abs=5e-3)
    assert result.n_blocks == 14
    assert result.n_algorithms == 4
    assert result.control == "C4.5+m+cf"
    # mushroom ties all four: mid-rank 2.5 each
    assert list(result.ranks.loc[9]) == [2.5, 2.5, 2.5, 2.5]


def test_demsar_holm_against_c45(demsar):
    """Demšar Sec. 3.2.2: C4.5 as the control, SE = 0.488; z = 2.416, 2.342, 0.512;
    p = 0.016, 0.019, 0.607 against Holm's 0.017, 0.025, 0.050: the first two rejected."""
    result = friedman_holm(demsar, "dataset", "classifier", "auc", higher_is_better=True, control="C4.5")
    table = result.comparisons.set_index("algorithm")
    assert list(table.index) == ["C4.5", "C4.5+m+cf", "C4.5+m", "C4.5+cf"]
    others = table.loc[["C4.5+m+cf", "C4.5+m", "C4.5+cf"]]
    assert np.abs(others["z"]).to_numpy() == pytest.approx([2.416, 2.342, 0.512], abs=2e-3)
    assert others["p"].to_numpy() == pytest.approx([0.016, 0.019, 0.607], abs=2e-3)
    assert others["holm_alpha"].to_numpy() == pytest.approx([0.05 / 3, 0.025, 0.05])
    assert list(others["significant"]) == [True, True, False]
    assert np.isnan(table.loc["C4.5", "p"])
    assert not table.loc["C4.5", "significant"]


# Yeguas Table 4 (39 DOF; 500, 1500 and 3000 evaluations) and Table 6 (H-PSO): average ranks
# over the 9 sequences, printed truncated to three decimals (1.222 = 11/9), so given here in
# ninths; the Friedman statistic and the p-value of each algorithm against the control. (Table
# 6's H-CMAES column prints 0.013 for a rank difference of 2.0, which Table 6's H-PSO column
# and the formula give as 0.023: a misprint, so that column is not used.)
YEGUAS = [
    ([11, 21, 27, 32, 46, 53, 63, 71], 57.925, [0.335, 0.123, 0.043, 7.57e-4, 5.31e-5, 5.62e-7, 7.76e-9]),
    ([18, 24, 25, 28, 43, 55, 63, 68], 49.148, [0.563, 0.500, 0.335, 0.016, 3.70e-4, 1.49e-5, 1.49e-6]),
    ([16, 22, 26, 36, 38, 56, 62, 68], 48.851, [0.563, 0.335, 0.054, 0.034, 1.18e-4, 9.58e-6, 5.62e-7]),
    ([14, 15, 32, 34, 41, 53], 36.111, [0.899, 0.023, 0.011, 6.69e-4, 8.94e-7]),
]


@pytest.mark.parametrize(("ninths", "chi2", "p_values"), YEGUAS)
def test_yeguas_tables_from_their_ranks(ninths, chi2, p_values):
    ranks = pd.Series(np.array(ninths) / 9.0, index=[f"a{i}" for i in range(len(ninths))])
    statistic, *_ = friedman_statistic(ranks.to_numpy(), 9)
    assert statistic == pytest.approx(chi2, abs=2e-3)
    table = holm_versus_control(ranks, 9)
    p = table["p"].to_numpy()[1:]
    big = np.array(p_values) >= 1e-3
    assert p[big] == pytest.approx(np.array(p_values)[big], abs=1.5e-3)
    assert p[~big] == pytest.approx(np.array(p_values)[~big], rel=2e-2)
    # the Holm column of the tables: alpha / (r - 1) for the algorithm ranked r
    k = len(ninths)
    assert table["holm_alpha"].to_numpy()[1:] == pytest.approx(0.05 / np.arange(1, k))


def test_cano_table3_ranks():
    """Cano Table 3 (m; 6 sequences x 12 mesh/evaluation configurations) and its ranks. The
    published errors are rounded to 0.1 mm, which creates ties the paper's own data did not
    have (s1_walking's two 0.0428): every rank agrees to within 1/12, half a rank in one block."""
    errors = [
        [0.0323, 0.0317, 0.0318, 0.0310, 0.0377, 0.0390, 0.0371, 0.0381, 0.0387, 0.0386, 0.0392, 0.0394],
        [0.0830, 0.0486, 0.0447, 0.0428, 0.0742, 0.0541, 0.0428, 0.0467, 0.0642, 0.0550, 0.0437, 0.0442],
        [0.0784, 0.0571, 0.0498, 0.0500, 0.0833, 0.0750, 0.0669, 0.0673, 0.0828, 0.0714, 0.0730, 0.0599],
        [0.0696, 0.0508, 0.0376, 0.0372, 0.0716, 0.0437, 0.0383, 0.0354, 0.0640, 0.0479, 0.0504, 0.0378],
        [0.0468, 0.0379, 0.0373, 0.0372, 0.0609, 0.0393, 0.0412, 0.0393, 0.0613, 0.0400, 0.0400, 0.0397],
        [0.1118, 0.0730, 0.0682, 0.0665, 0.1179, 0.0799, 0.0690, 0.0675, 0.1125, 0.0981, 0.0811, 0.0787],
    ]
    published = [9.50, 4.83, 2.83, 1.50, 10.67, 7.33, 4.83, 4.50, 10.50, 8.00, 7.50, 6.00]
    names = [f"c{i:02d}" for i in range(12)]
    result = friedman_holm(long_table(errors, names), "block", "algorithm", "value")
    ranks = result.comparisons.set_index("algorithm")["rank"][names].to_numpy()
    assert ranks == pytest.approx(published, abs=1 / 12 + 5e-3)
    assert np.sum(np.abs(ranks - published) < 5e-3) >= 6


def test_statistic_equals_scipy_without_ties():
    rng = np.random.default_rng(3)
    values = rng.normal(size=(7, 5)) + np.arange(5) * 0.3
    result = friedman_holm(long_table(values, list("abcde")), "block", "algorithm", "value")
    expected = stats.friedmanchisquare(*values.T)
    assert result.statistic == pytest.approx(expected.statistic)
    assert result.p_value == pytest.approx(expected.pvalue)


def test_ties_get_mid_ranks_and_lower_is_better():
    matrix = pd.DataFrame([[1.0, 2.0, 2.0, 3.0], [5.0, 5.0, 5.0, 1.0]], columns=list("abcd"))
    assert block_ranks(matrix).to_numpy().tolist() == [[1, 2.5, 2.5, 4], [3, 3, 3, 1]]
    assert block_ranks(matrix, higher_is_better=True).to_numpy().tolist() == [[4, 2.5, 2.5, 1], [2, 2, 2, 4]]


def test_holm_steps_down_and_stops_at_the_first_retained():
    """K = 4: thresholds 0.05/3, 0.05/2, 0.05. p = 0.01 passes, 0.03 fails its 0.025, so
    0.04 is retained although it is below 0.05; adjusted p = 0.03, 0.06, 0.06."""
    n = 60
    se = np.sqrt(4 * 5 / (6 * n))
    z = {"A": stats.norm.isf(0.005), "B": stats.norm.isf(0.015), "C": stats.norm.isf(0.02)}
    ranks = pd.Series({"ctrl": 1.0, **{name: 1.0 + v * se for name, v in z.items()}})
    table = holm_versus_control(ranks, n).set_index("algorithm")
    assert list(table.index) == ["ctrl", "C", "B", "A"]  # by rank
    assert table["p"][["A", "B", "C"]].to_numpy() == pytest.approx([0.01, 0.03, 0.04])
    assert table["holm_alpha"][["A", "B", "C"]].to_numpy() == pytest.approx([0.05 / 3, 0.025, 0.05])
    assert list(table["significant"]) == [False, False, False, True]
    assert table["holm_p"][["A", "B", "C"]].to_numpy() == pytest.approx([0.03, 0.06, 0.06])
    assert holm_versus_control(ranks, n, alpha=0.1)["significant"].tolist() == [False, True, True, True]


def test_several_rows_per_cell_are_averaged():
    rows = pd.DataFrame(
        {
            "sequence": ["s1"] * 4 + ["s2"] * 3,
            "algorithm": ["a", "a", "b", "c", "a", "b", "c"],
            "value": [1.0, 9.0, 4.0, 6.0, 1.0, 2.0, 3.0],
        }
    )
    result = friedman_holm(rows, "sequence", "algorithm", "value")
    assert result.ranks.loc["s1"].tolist() == [2.0, 1.0, 3.0]  # a: mean of 1 and 9 = 5
    assert result.ranks.loc["s2"].tolist() == [1.0, 2.0, 3.0]


def test_incomplete_blocks_are_dropped_with_a_warning():
    values = [[1, 2, 3], [1, 3, 2], [2, 1, 3]]
    table = long_table(values, list("abc"))
    table = table[~((table.block == 1) & (table.algorithm == "c"))]
    with pytest.warns(IncompleteBlocksWarning, match=r"block 1 \(no c\)|1 \(no c\)"):
        result = friedman_holm(table, "block", "algorithm", "value")
    assert result.n_blocks == 2
    assert result.dropped == ["1"]


BAD = [
    (lambda t: t.drop(columns="value"), "missing column(s) 'value'"),
    (lambda t: t[t.algorithm != "c"], "at least 3 values of 'algorithm', got 2"),
    (lambda t: t[t.block == 0], "at least 2 blocks (block) with a value for every algorithm, got 1"),
    (
        lambda t: t.assign(value=t.value.astype(object).where(t.index != 4, "fast")),
        "'value' holds 1 value(s) that are not numbers, the first 'fast' in data row 5",
    ),
    (
        lambda t: t.assign(value=t.value.where(t.index != 2, np.nan)),
        "'value' holds 1 NaN or infinite value(s) (an empty cell is NaN), the first in data row 3",
    ),
    (lambda t: t.assign(value=t.value.where(t.index != 0, np.inf)), "NaN or infinite"),
    (
        lambda t: t.assign(algorithm=t.algorithm.where(t.index != 1, None)),
        "column 'algorithm' has 1 empty cell(s), the first in data row 2",
    ),
]


@pytest.mark.parametrize(("damage", "message"), BAD)
def test_bad_input_is_a_clear_error(damage, message):
    table = damage(long_table([[1, 2, 3], [1, 3, 2], [2, 1, 3]], list("abc")))
    with pytest.raises(DataError) as err:
        friedman_holm(table, "block", "algorithm", "value", source="results.csv")
    assert str(err.value).startswith("results.csv: ")
    assert message in str(err.value)


def test_unknown_control_and_bad_alpha():
    table = long_table([[1, 2, 3], [1, 3, 2]], list("abc"))
    with pytest.raises(DataError, match="control algorithm 'z' not among a, b, c"):
        friedman_holm(table, "block", "algorithm", "value", control="z")
    with pytest.raises(DataError, match="alpha must be in"):
        friedman_holm(table, "block", "algorithm", "value", alpha=5)


def test_read_table_skips_provenance_lines_and_names_missing_files(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("# mmocap 0.1.0\n# second\nblock,algorithm,value\n0,a,1.5\n")
    assert read_table(path).to_dict("list") == {"block": [0], "algorithm": ["a"], "value": [1.5]}
    with pytest.raises(DataError, match="nope.csv: no such file"):
        read_table(tmp_path / "nope.csv")


def test_read_table_refuses_what_is_not_one_table(tmp_path):
    cases = {
        "empty.csv": ("", "is empty"),
        "binary.csv": ("a,b\n\0\1,2\n", "binary data"),
        "twice.csv": ("block,value,value\n0,1,2\n", "'value' appear more than once"),
    }
    for name, (text, message) in cases.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(DataError, match=message):
            read_table(tmp_path / name)
    with pytest.raises(DataError, match="is a folder"):
        read_table(tmp_path)


def test_numbers_as_algorithm_names_match_the_control_as_text():
    table = long_table([[3, 1, 2], [3, 2, 1], [1, 2, 3]], [10, 20, 30])
    for control in ("20", 20):
        result = friedman_holm(table, "block", "algorithm", "value", control=control)
        assert result.control == "20"
        assert result.comparisons["algorithm"].tolist()[0] == "20"


def test_cell_means_near_the_float_limit_rank_as_moderate_values():
    # two rows per cell; the plain sum of a's 1.6e308 and 1.7e308 overflows to inf (rank 3)
    moderate = pd.DataFrame(
        {
            "block": [0, 0, 0, 0, 1, 1, 1, 1],
            "algorithm": list("aabcaabc"),
            "value": [1.6, 1.7, 1.66, 1.75, 1.0, 1.1, 1.2, 1.3],
        }
    )
    huge = moderate.assign(value=moderate.value * 1e308)
    with np.errstate(over="ignore"):
        assert np.isinf(huge.value.to_numpy()[:2].sum())
    a = friedman_holm(moderate, "block", "algorithm", "value")
    b = friedman_holm(huge, "block", "algorithm", "value")
    assert b.ranks.loc[0].tolist() == [1.0, 2.0, 3.0] == a.ranks.loc[0].tolist()
    assert b.statistic == a.statistic
    assert b.comparisons["p"].equals(a.comparisons["p"])
    assert overflow_free_mean([1.6e308, 1.7e308]) == pytest.approx(1.65e308, rel=1e-15)


def test_cells_with_equal_exact_means_tie():
    """The issue's case: 16/3 as the sum of v / 3 is 5.333333333333333 for [6, 6, 4] and
    5.333333333333334 for [6, 5, 5]; ranked on exact means, a and b share ranks 1.5 or 2.5."""
    table = pd.DataFrame(
        {
            "block": [0] * 7 + [1] * 3,
            "algorithm": list("aaabbbc") + list("abc"),
            "value": [6.0, 6.0, 4.0, 6.0, 5.0, 5.0, 9.0, 1.0, 2.0, 3.0],
        }
    )
    result = friedman_holm(table, "block", "algorithm", "value")
    assert result.ranks.loc[0].tolist() == [1.5, 1.5, 3.0]
    assert overflow_free_mean([6.0, 6.0, 4.0]) == overflow_free_mean([5.0, 6.0, 5.0]) == 16 / 3
    # rounded once: 1 + 2**-53 is halfway between two floats and goes to the even one
    assert overflow_free_mean([1.0, 1.0 + 2**-52]) == 1.0
    assert overflow_free_mean([5e-324, 5e-324, 0.0]) == 5e-324  # 2/3 of the smallest subnormal
    assert np.isnan(overflow_free_mean([1.0, np.nan]))
    assert overflow_free_mean([-1.7976931348623157e308, -1.7976931348623157e308]) == -1.7976931348623157e308


def test_blocks_that_all_rank_alike_give_an_unbounded_f():
    """Seven algorithms ranked alike on 79 blocks: chi2_F = N(k-1) = 474 exactly, so F_F =
    (N-1) chi2_F / 0; in floats the formula left 474 - 5.7e-14 and F_F = 6.5e17."""
    chi2, p, f, p_f = friedman_statistic(np.arange(1.0, 8.0), 79)
    assert chi2 == 474.0
    assert f == np.inf
    assert p_f == 0.0
    assert p == pytest.approx(stats.chi2.sf(474.0, 6))


# Generated tables: the pools draw values with ties (small integers, the float limits, the
# smallest subnormal, any float); a twin cell has another algorithm's exact mean from other
# values (a shifted pair of integers, the values reordered or each repeated).
POOLS = {
    "integers": st.integers(-3, 6).map(float),
    "limits": st.sampled_from([1.7976931348623157e308, -1.7976931348623157e308, 1e308, 8.9e307, -0.0, 5e-324]),
    "subnormal": st.integers(-4, 4).map(lambda i: i * 5e-324),
    "any": st.one_of(st.floats(allow_nan=False, allow_infinity=False), st.sampled_from([0.1, 0.2, 0.3, 1e-300])),
}


def twin(values: list[float], how: str) -> list[float]:
    """Values other than ``values`` with the same exact mean."""
    if how == "shifted" and len(values) >= 2 and all(abs(v) < 2**50 and v == int(v) for v in values[:2]):
        return [values[0] + 1.0, values[1] - 1.0, *values[2:]]
    if how == "repeated":
        return values * 2
    return values[::-1]


@st.composite
def long_tables(draw):
    """(long table, 'block (no algorithm)' of each incomplete block): k = 3-5 algorithms, 2-6 complete blocks
    and up to 2 incomplete ones, 1-3 rows a cell (or 4-6 for a repeated twin), rows shuffled."""
    k, complete, incomplete = draw(st.integers(3, 5)), draw(st.integers(2, 6)), draw(st.integers(0, 2))
    pool, twins = (
        POOLS[draw(st.sampled_from(sorted(POOLS)))],
        draw(st.sampled_from(["none", "shifted", "reordered", "repeated"])),
    )
    names = [f"a{j}" for j in range(k)]
    rows, lacking = [], []
    for block in range(complete + incomplete):
        cells = [draw(st.lists(pool, min_size=1, max_size=3)) for _ in names]
        if twins != "none":
            cells[1] = twin(cells[0], twins)
        if block >= complete:
            missing = draw(st.integers(0, k - 1))
            cells[missing] = []
            lacking.append(f"{block} (no {names[missing]})")
        rows += [(block, name, v) for name, values in zip(names, cells) for v in values]
    table = pd.DataFrame(draw(st.permutations(rows)), columns=["block", "algorithm", "value"])
    return table, lacking


def reference(table: pd.DataFrame, higher_is_better: bool) -> dict:
    """What the textbook gives (Demšar 2006; García and Herrera 2008) over the blocks with
    every algorithm: cell means, scipy's mid-ranks, then the formulas. A cell mean is the
    exact mean (the floats as fractions) rounded to the nearest float. ``exact_ties``:
    (block, i, j) of the cells i, j whose exact means are equal."""
    cells: dict[tuple, list[Fraction]] = {}
    for block, name, v in table.itertuples(index=False):
        cells.setdefault((block, name), []).append(Fraction(float(v)))
    names = sorted(table.algorithm.unique())
    blocks = sorted({b for b, _ in cells if all((b, n) in cells for n in names)})
    ranks, exact_ties = [], []
    for b, block in enumerate(blocks):
        exact = [sum(cells[block, n]) / len(cells[block, n]) for n in names]
        means = np.array([float(m) for m in exact])
        ranks.append(stats.rankdata(-means if higher_is_better else means, method="average"))
        exact_ties += [(b, i, j) for i, j in itertools.combinations(range(len(names)), 2) if exact[i] == exact[j]]
    ranks = np.array(ranks)
    n, k = ranks.shape
    rank_sums = [Fraction(int(2 * s), 2) for s in ranks.sum(axis=0)]
    chi2 = Fraction(12, n * k * (k + 1)) * sum(s * s for s in rank_sums) - 3 * n * (k + 1)
    unbounded = chi2 == n * (k - 1)
    f = math.inf if unbounded else float((n - 1) * chi2 / (n * (k - 1) - chi2))
    average = ranks.mean(axis=0)
    control = int(np.argmin(average))
    z = (average - average[control]) / math.sqrt(k * (k + 1) / (6 * n))
    p = 2 * stats.norm.sf(np.abs(z))
    others = sorted((i for i in range(k) if i != control), key=lambda i: p[i])
    holm = np.maximum.accumulate([min(1.0, (k - 1 - j) * p[i]) for j, i in enumerate(others)])
    return {
        "ranks": ranks,
        "exact_ties": exact_ties,
        "chi2": float(chi2),
        "p": stats.chi2.sf(float(chi2), k - 1),
        "f": f,
        "p_f": 0.0 if unbounded else stats.f.sf(f, k - 1, (k - 1) * (n - 1)),
        "control": names[control],
        "z": {names[i]: z[i] for i in others},
        "p_each": {names[i]: p[i] for i in others},
        "holm_p": {names[i]: h for i, h in zip(others, holm)},
    }


@given(long_tables(), st.booleans())
def test_generated_tables_agree_with_rankdata_and_the_formulas(drawn, higher_is_better):
    table, incomplete = drawn
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = friedman_holm(table, "block", "algorithm", "value", higher_is_better=higher_is_better)
    assert [w.category for w in caught] == [IncompleteBlocksWarning] * bool(incomplete)
    assert all(block in str(caught[0].message) for block in incomplete)
    assert result.dropped == [block.split()[0] for block in incomplete]
    want = reference(table, higher_is_better)
    ranks = result.ranks.to_numpy()
    assert all(ranks[b, i] == ranks[b, j] for b, i, j in want["exact_ties"])
    np.testing.assert_array_equal(ranks, want["ranks"])
    assert result.statistic == pytest.approx(want["chi2"], rel=1e-12, abs=1e-12)
    assert result.p_value == pytest.approx(want["p"], rel=1e-9, abs=1e-300)
    assert result.iman_davenport == pytest.approx(want["f"], rel=1e-9)
    assert result.iman_davenport_p == pytest.approx(want["p_f"], rel=1e-9, abs=1e-300)
    comparisons = result.comparisons.set_index("algorithm")
    assert result.control == want["control"]
    for name, z in want["z"].items():
        assert comparisons.loc[name, "z"] == pytest.approx(z, rel=1e-12, abs=1e-12)
        assert comparisons.loc[name, "p"] == pytest.approx(want["p_each"][name], rel=1e-9, abs=1e-300)
        assert comparisons.loc[name, "holm_p"] == pytest.approx(want["holm_p"][name], rel=1e-9, abs=1e-300)
        assert comparisons.loc[name, "significant"] == (want["holm_p"][name] <= 0.05)


def test_an_error_names_the_row_in_the_file_after_filtering():
    table = long_table([[1, 2, 3], [1, 3, 2], [2, 1, 3]], list("abc"))
    table.loc[7, "value"] = np.nan  # block 2, algorithm b: data row 8 of its file
    with pytest.raises(DataError, match="the first in data row 8"):
        friedman_holm(table[table.block > 0], "block", "algorithm", "value")


def test_whole_numbers_and_empty_cells_name_the_first_bad_cell():
    table = pd.DataFrame({"dof": [39, 28.0, "39.5", None], "name": ["a", None, "c", None]})
    assert whole_numbers(table.iloc[:2], "dof", "runs.csv").tolist() == [39, 28]
    with pytest.raises(
        DataError,
        match=r"runs.csv: column 'dof' must hold whole numbers; 2 cell\(s\) do not, "
        r"the first '39.5' in data row 3",
    ):
        whole_numbers(table, "dof", "runs.csv")
    with pytest.raises(DataError, match="the first an empty cell in data row 4"):
        whole_numbers(table.iloc[[0, 3]], "dof", "runs.csv")
    with pytest.raises(DataError, match=r"column 'name' has 2 empty cell\(s\), the first in data row 2"):
        no_empty_cells(table, ["name"], "runs.csv")


def test_missing_values_may_be_let_through_but_never_text_or_inf():
    table = pd.DataFrame({"error": [1.0, np.nan, 2.0]})
    assert np.isnan(finite_numbers(table, "error", "f.csv", missing_ok=True)[1])
    with pytest.raises(DataError, match="1 infinite value"):
        finite_numbers(table.assign(error=[1.0, np.nan, np.inf]), "error", "f.csv", missing_ok=True)


def test_the_summary_says_how_many_incomplete_blocks_were_left_out():
    table = long_table([[1, 2, 3], [1, 3, 2], [2, 1, 3]], list("abc"))
    with pytest.warns(IncompleteBlocksWarning) as caught:
        result = friedman_holm(table.drop(index=4), "block", "algorithm", "value")
    assert issubclass(caught[0].category, MmocapWarning)
    assert result.summary().endswith("; 1 incomplete block(s) left out")
    assert "left out" not in friedman_holm(table, "block", "algorithm", "value").summary()


def stats_cli(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "mmocap", "stats", *args], cwd=cwd, capture_output=True, text=True, timeout=120
    )


def test_cli_prints_and_writes_the_table(tmp_path, demsar):
    demsar.to_csv(tmp_path / "auc.csv", index=False)
    out = stats_cli(
        "auc.csv",
        "--block",
        "dataset",
        "--algorithm",
        "classifier",
        "--value",
        "auc",
        "--higher-is-better",
        "--control",
        "C4.5",
        "--out",
        "tables/demsar",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    assert "chi2_F = 9.279" in out.stdout
    assert "Iman-Davenport F_F = 3.686" in out.stdout
    assert "| C4.5+m+cf " in out.stdout
    written = pd.read_csv(tmp_path / "tables/demsar.csv", comment="#")
    assert written["Algorithm"].tolist() == ["C4.5", "C4.5+m+cf", "C4.5+m", "C4.5+cf"]
    assert written["Significant"].tolist() == [False, True, True, False]
    assert (tmp_path / "tables/demsar.csv").read_text().startswith("# mmocap ")
    tex = (tmp_path / "tables/demsar.tex").read_text()
    assert r"\toprule" in tex
    assert "C4.5+m+cf &" in tex
    assert "| C4.5+cf " in (tmp_path / "tables/demsar.md").read_text()


def test_cli_bad_input_is_one_line_and_exit_2(tmp_path, demsar):
    demsar.to_csv(tmp_path / "auc.csv", index=False)
    out = stats_cli("auc.csv", "--block", "dataset", "--algorithm", "classifier", cwd=tmp_path)
    assert out.returncode == 2
    assert out.stderr == (
        "mmocap: error: auc.csv: missing column(s) 'mean_marker_error_mm'; columns are dataset, classifier, auc\n"
    )
    out = stats_cli("missing.csv", cwd=tmp_path)
    assert out.returncode == 2
    assert out.stderr == "mmocap: error: missing.csv: no such file\n"
