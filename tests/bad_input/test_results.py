"""Bad results tables and run records: `mmocap stats`, `collect`, `summaries` and `paper`
give one line naming the file, column or block, or the right answer."""
import json
from pathlib import Path

import numpy as np
import pytest

from tests.bad_input.conftest import assert_clean_error, mmocap

HEADER = "sequence,seed,algorithm,mean_marker_error_mm"


def table(tmp_path, text: str, name: str = "runs.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def good_rows(algorithms=("a", "b", "c"), seeds=range(4), scale=1.0, repeats=1) -> list[str]:
    """Rows where each algorithm's value grows with its index, with some noise per seed."""
    rng = np.random.default_rng(0)
    return [f"S1_walking,{s},{a},{scale * (1 + i + 0.9 * rng.random())!r}"
            for s in seeds for i, a in enumerate(algorithms) for _ in range(repeats)]


def rows_of(outcome) -> list[str]:
    """The markdown rows of the comparison table that `mmocap stats` prints."""
    return [line for line in outcome.stdout.splitlines() if line.startswith("| ")]


BAD_TABLES = {
    "empty-file": ("", "not a readable table"),
    "header-only": (HEADER + "\n", "no data rows"),
    "no-value-column": ("sequence,seed,algorithm\nS1,0,a\n", "mean_marker_error_mm"),
    "text-value": (HEADER + "\n" + "\n".join(good_rows()[:-1] + ["S1_walking,3,c,lots"]) + "\n", "lots"),
    "nan-value": (HEADER + "\n" + "\n".join(good_rows()[:-1] + ["S1_walking,3,c,nan"]) + "\n", "NaN"),
    "inf-value": (HEADER + "\n" + "\n".join(good_rows()[:-1] + ["S1_walking,3,c,inf"]) + "\n", "infinite"),
    "duplicated-column": (HEADER + ",mean_marker_error_mm\n" + "\n".join(r + ",1" for r in good_rows()) + "\n",
                          "more than once"),
    "two-algorithms": (HEADER + "\n" + "\n".join(good_rows(("a", "b"))) + "\n", "at least 3"),
    "one-block": (HEADER + "\n" + "\n".join(good_rows(seeds=[0])) + "\n", "at least 2 blocks"),
    "empty-algorithm-cell": (HEADER + "\n" + "\n".join(good_rows()[:-1] + ["S1_walking,3,,2.0"]) + "\n",
                             "empty cells"),
    "binary": ("\x00\x01\x02\xff\xfe", "missing column"),
}


@pytest.mark.parametrize("case", list(BAD_TABLES))
def test_a_bad_table_names_the_file_and_the_problem(tmp_path, case):
    text, problem = BAD_TABLES[case]
    path = table(tmp_path, text)
    assert_clean_error(mmocap("stats", path), "runs.csv", problem)


def test_the_algorithm_column_as_a_block_is_refused(tmp_path):
    path = table(tmp_path, HEADER + "\n" + "\n".join(good_rows()) + "\n")
    assert_clean_error(mmocap("stats", path, "--block", "algorithm"), "'algorithm'", "more than one role")


def test_unknown_columns_and_control_are_named(tmp_path):
    path = table(tmp_path, HEADER + "\n" + "\n".join(good_rows()) + "\n")
    assert_clean_error(mmocap("stats", path, "--value", "fitness"), "fitness")
    assert_clean_error(mmocap("stats", path, "--control", "d"), "'d'")


def test_numbers_as_algorithm_names_can_be_the_control(tmp_path):
    path = table(tmp_path, HEADER + "\n" + "\n".join(good_rows(("1", "2", "3"))) + "\n")
    outcome = mmocap("stats", path, "--control", "2")
    assert outcome.code == 0, outcome
    assert "Holm vs control 2" in outcome.stdout


def test_values_near_the_float_limit_rank_as_moderate_ones(tmp_path):
    # two measurements per block and algorithm: their sum would overflow to inf
    moderate = table(tmp_path, HEADER + "\n" + "\n".join(good_rows(repeats=2)) + "\n", "moderate.csv")
    huge = table(tmp_path, HEADER + "\n" + "\n".join(good_rows(scale=1e308 / 3, repeats=2)) + "\n", "huge.csv")
    a, b = mmocap("stats", moderate), mmocap("stats", huge)
    assert a.code == b.code == 0, (a, b)
    assert rows_of(a) and rows_of(a) == rows_of(b)


def test_an_unbalanced_block_is_left_out_with_a_warning_naming_it(tmp_path):
    rows = [r for r in good_rows() if not r.startswith("S1_walking,2,b,")]
    outcome = mmocap("stats", table(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n"))
    assert outcome.code == 0, outcome
    assert "S1_walking/2 (no b)" in outcome.stderr and "1 block(s)" in outcome.stderr


def store_with(tmp_path, record) -> Path:
    records = tmp_path / "sweep" / "records"
    records.mkdir(parents=True)
    (records / "abc.json").write_text(record if isinstance(record, str) else json.dumps(record))
    return tmp_path / "sweep"


@pytest.mark.parametrize("record, problem", [
    ({"run_id": "abc", "seed": 0, "timings": {}, "provenance": {}}, "lacks summary"),
    ({"run_id": "abc", "seed": 0, "summary": {"subject": "S1"}, "timings": {}, "provenance": {}},
     "summary.mean_marker_error_mm"),
    ('{"run_id": "ab', "not valid JSON"),
], ids=["no-summary", "summary-without-error", "truncated"])
def test_collect_names_a_broken_record(tmp_path, record, problem):
    assert_clean_error(mmocap("collect", store_with(tmp_path, record)), "abc.json", problem)


def test_summaries_names_a_truncated_summary(tmp_path):
    run = tmp_path / "runs" / "r1"
    run.mkdir(parents=True)
    (run / "summary.json").write_text('{"optimizer": "cma')
    assert_clean_error(mmocap("summaries", tmp_path / "runs"), "summary.json", "not valid JSON")


def test_paper_names_the_missing_columns(tmp_path):
    folder = tmp_path / "sweep"
    folder.mkdir()
    (folder / "runs.csv").write_text("run_id,subject\nx,S1\n")
    assert_clean_error(mmocap("paper", "table4", folder), "runs.csv", "missing column")
