"""Bad results tables and run records: `mmocap stats`, `collect`, `summaries`, `paper` and
`foreground-quality` give one line naming the file, column, block or option, or the right
answer (numbers as algorithm names, values near the float limit, incomplete blocks)."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mmocap.analysis.results import SCHEMA
from tests.helpers import assert_clean_error, track_args
from tests.helpers import mmocap_in_process as mmocap

HEADER = "sequence,seed,algorithm,mean_marker_error_mm"


def table(tmp_path, text: str, name: str = "runs.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def good_rows(algorithms=("a", "b", "c"), seeds=range(4), scale=1.0, repeats=1) -> list[str]:
    """Rows where each algorithm's value grows with its index, with some noise per seed."""
    rng = np.random.default_rng(0)
    return [
        f"S1_walking,{s},{a},{scale * (1 + i + 0.9 * rng.random())!r}"
        for s in seeds
        for i, a in enumerate(algorithms)
        for _ in range(repeats)
    ]


def csv_of(rows: list[str], header: str = HEADER) -> str:
    return header + "\n" + "\n".join(rows) + "\n"


def last_replaced(cell: str) -> str:
    """The good table with the value of its last row replaced by ``cell``."""
    rows = good_rows()
    return csv_of(rows[:-1] + [rows[-1].rsplit(",", 1)[0] + "," + cell])


def rows_of(outcome) -> list[str]:
    """The markdown rows of the comparison table that `mmocap stats` prints."""
    return [line for line in outcome.stdout.splitlines() if line.startswith("| ")]


# ------------------------------------------------------------------ mmocap stats: the table

BAD_TABLES = {
    "empty-file": ("", ("is empty",)),
    "header-only": (HEADER + "\n", ("no data rows",)),
    "no-value-column": ("sequence,seed,algorithm\nS1,0,a\n", ("'mean_marker_error_mm'",)),
    "text-value": (last_replaced("lots"), ("'mean_marker_error_mm'", "'lots'", "data row 12")),
    "nan-value": (last_replaced("nan"), ("'mean_marker_error_mm'", "NaN", "data row 12")),
    "inf-value": (last_replaced("inf"), ("'mean_marker_error_mm'", "infinite", "data row 12")),
    "empty-value-cell": (last_replaced(""), ("'mean_marker_error_mm'", "empty cell", "data row 12")),
    "duplicated-column": (
        csv_of([r + ",1" for r in good_rows()], HEADER + ",mean_marker_error_mm"),
        ("'mean_marker_error_mm'", "more than once"),
    ),
    "one-algorithm": (csv_of(good_rows(("a",))), ("at least 3", "'algorithm'", "got 1")),
    "two-algorithms": (csv_of(good_rows(("a", "b"))), ("at least 3", "'algorithm'", "got 2")),
    "one-block": (csv_of(good_rows(seeds=[0])), ("at least 2 blocks", "got 1")),
    "empty-algorithm-cell": (
        csv_of(good_rows()[:-1] + ["S1_walking,3,,2.0"]),
        ("'algorithm'", "1 empty cell", "data row 12"),
    ),
    "empty-block-cell": (csv_of(["S1_walking,,a,2.0"] + good_rows()), ("'seed'", "1 empty cell", "data row 1")),
    "ragged-row": (csv_of(good_rows() + ["S1_walking,4,a,1.0,9"]), ("not a readable table",)),
    "binary": ("\x00\x01\x02\xff\xfe", ("not a readable table",)),
}


@pytest.mark.parametrize("case", list(BAD_TABLES))
def test_a_bad_table_names_the_file_and_the_problem(tmp_path, case):
    text, culprits = BAD_TABLES[case]
    path = table(tmp_path, text)
    assert_clean_error(mmocap("stats", path), str(path), *culprits)


def test_a_folder_given_as_the_table_is_named(tmp_path):
    assert_clean_error(mmocap("stats", tmp_path), str(tmp_path), "is a folder")


# ------------------------------------------------------------------ mmocap stats: the options

BAD_OPTIONS = {
    "algorithm-as-block": (["--block", "algorithm"], ("'algorithm'", "more than one role")),
    "value-as-block": (["--block", "sequence,mean_marker_error_mm"], ("'mean_marker_error_mm'", "more than one role")),
    "unknown-value-column": (["--value", "fitness"], ("'fitness'", "missing column")),
    "unknown-control": (["--control", "d"], ("control algorithm 'd'", "a, b, c")),
    "alpha-above-one": (["--alpha", "5"], ("--alpha", "(0, 1)")),
    "alpha-nan": (["--alpha", "nan"], ("--alpha",)),
}


@pytest.mark.parametrize("case", list(BAD_OPTIONS))
def test_a_bad_option_is_named(tmp_path, case):
    options, culprits = BAD_OPTIONS[case]
    path = table(tmp_path, csv_of(good_rows()))
    assert_clean_error(mmocap("stats", path, *options), *culprits)


def test_out_naming_a_folder_is_refused_before_the_test(tmp_path):
    path = table(tmp_path, csv_of(good_rows()))
    (tmp_path / "tables").mkdir()
    outcome = mmocap("stats", path, "--out", tmp_path / "tables")
    assert_clean_error(outcome, "--out", str(tmp_path / "tables"), "is a folder")
    assert outcome.stdout == ""
    assert list((tmp_path / "tables").iterdir()) == []


def test_out_under_a_file_names_the_file(tmp_path):
    path = table(tmp_path, csv_of(good_rows()))
    blocker = table(tmp_path, "not a folder\n", "notes.txt")
    outcome = mmocap("stats", path, "--out", blocker / "friedman")
    assert_clean_error(outcome, str(blocker), "is a file")
    assert outcome.stdout == "", "the test ran although its output could not be written"


def test_out_in_a_read_only_folder_names_the_folder(tmp_path, make_read_only):
    path = table(tmp_path, csv_of(good_rows()))
    (tmp_path / "locked").mkdir()
    folder = make_read_only(tmp_path / "locked")
    assert_clean_error(mmocap("stats", path, "--out", folder / "friedman"), str(folder))
    assert list(folder.iterdir()) == []


# ------------------------------------------------------------------ mmocap stats: right answers


def test_numbers_as_algorithm_names_can_be_the_control(tmp_path):
    path = table(tmp_path, csv_of(good_rows(("1", "2", "3"))))
    outcome = mmocap("stats", path, "--control", "2")
    assert outcome.code == 0, outcome
    assert "Holm vs control 2" in outcome.stdout
    assert rows_of(outcome)[1].startswith("| 2 ")  # the control is the first row below the header


def test_values_near_the_float_limit_rank_as_moderate_ones(tmp_path):
    # two measurements per block and algorithm: their sum would overflow to inf
    moderate = table(tmp_path, csv_of(good_rows(repeats=2)), "moderate.csv")
    huge = table(tmp_path, csv_of(good_rows(scale=1e308 / 3, repeats=2)), "huge.csv")
    a, b = mmocap("stats", moderate), mmocap("stats", huge)
    assert a.code == b.code == 0, (a, b)
    assert rows_of(a)
    assert rows_of(a) == rows_of(b)
    assert rows_of(b)[1].startswith("| a ")  # a, the lowest, is the best-ranked, not an inf


def test_an_incomplete_block_is_left_out_with_a_warning_naming_it(tmp_path):
    rows = [r for r in good_rows() if not r.startswith("S1_walking,2,b,")]
    outcome = mmocap("stats", table(tmp_path, csv_of(rows)))
    assert outcome.code == 0, outcome
    warning = [line for line in outcome.stderr.splitlines() if line.startswith("mmocap: warning:")]
    assert len(warning) == 1
    assert "1 block(s)" in warning[0]
    assert "S1_walking/2 (no b)" in warning[0]
    assert "3 algorithms on 3 blocks" in outcome.stdout
    assert "1 incomplete block(s) left out" in outcome.stdout


# ------------------------------------------------------------------ mmocap collect: run records


def store_with(tmp_path, record) -> Path:
    records = tmp_path / "sweep" / "records"
    records.mkdir(parents=True)
    (records / "abc.json").write_text(record if isinstance(record, str) else json.dumps(record))
    return tmp_path / "sweep"


def good_record(**changes) -> dict:
    """A complete record of a 2-frame run; ``changes`` replace whole parts of it."""
    record = {
        "run_id": "abc",
        "seed": 0,
        "summary": {
            "subject": "S1",
            "action": "walking",
            "optimizer": "cmaes",
            "strategy": "holistic",
            "dof": 39,
            "evaluations_per_frame": 150,
            "vertices": 1000,
            "backend": "numpy",
            "frames": 2,
            "mean_marker_error_mm": 15.0,
        },
        "timings": {"seconds_per_frame": 0.5, "evaluation_seconds_per_frame": 0.4},
        "provenance": {"git_commit": "0" * 40, "host": "here"},
        "frames": [
            {"frame": 0, "marker_error_mm": 10.0, "fitness": 0.1},
            {"frame": 1, "marker_error_mm": 20.0, "fitness": 0.2},
        ],
    }
    return {**record, **changes}


BAD_RECORDS = {
    "no-summary": ({k: v for k, v in good_record().items() if k != "summary"}, ("lacks summary",)),
    "summary-without-error": (
        good_record(summary={k: v for k, v in good_record()["summary"].items() if k != "mean_marker_error_mm"}),
        ("lacks summary.mean_marker_error_mm",),
    ),
    "truncated": ('{"run_id": "ab', ("not valid JSON",)),
    "not-an-object": ("[1, 2]", ("not a JSON object",)),
    "text-dof": (
        good_record(summary={**good_record()["summary"], "dof": "many"}),
        ("summary.dof", "'many'", "an integer"),
    ),
    "frame-without-error": (good_record(frames=[{"frame": 0}]), ("frames[0].marker_error_mm",)),
    "text-schema": (good_record(schema="two"), ("schema is 'two'", "whole number")),
    "newer-schema": (good_record(schema=SCHEMA + 1), (f"schema {SCHEMA + 1}", "newer than this mmocap's")),
}


@pytest.mark.parametrize("case", list(BAD_RECORDS))
def test_collect_names_a_broken_record(tmp_path, case):
    record, culprits = BAD_RECORDS[case]
    store = store_with(tmp_path, record)
    assert_clean_error(mmocap("collect", store), str(store / "records" / "abc.json"), *culprits)
    assert not (store / "runs.csv").exists()


#: a store.json -> what the one line says besides its path
BAD_STORE_FILES = {
    "newer-schema": (json.dumps({"schema": SCHEMA + 1}), (f"schema {SCHEMA + 1}", "newer than this mmocap's")),
    "text-schema": (json.dumps({"schema": "1"}), ("schema is '1'", "not a whole number")),
    "truncated": ('{"sche', ("not valid JSON",)),
}


@pytest.mark.parametrize("case", list(BAD_STORE_FILES))
def test_a_run_into_a_store_it_cannot_use_is_refused_before_it_runs(tiny_original, tmp_path, case):
    text, culprits = BAD_STORE_FILES[case]
    store = tmp_path / "store"
    store.mkdir()
    (store / "store.json").write_text(text)
    outcome = mmocap(*track_args(tiny_original, tmp_path / "run"), f"results.store={store}")
    assert_clean_error(outcome, str(store / "store.json"), *culprits)
    assert not (store / "records").exists()


def test_collect_keeps_a_run_without_ground_truth_empty_and_says_so(tmp_path):
    record = good_record(
        summary={**good_record()["summary"], "mean_marker_error_mm": None},
        frames=[{"frame": 0, "marker_error_mm": None, "fitness": 0.1}],
    )
    store = store_with(tmp_path, record)
    outcome = mmocap("collect", store)
    assert outcome.code == 0, outcome
    assert "mmocap: warning: 1 of 1 run(s)" in outcome.stderr
    assert "no ground truth" in outcome.stderr
    runs, frames = pd.read_csv(store / "runs.csv"), pd.read_csv(store / "frames.csv")
    assert runs["mean_marker_error_mm"].isna().all()
    assert frames["marker_error_mm"].isna().all()
    # and the statistics refuse it rather than average it away
    assert_clean_error(mmocap("stats", store / "runs.csv"), "'mean_marker_error_mm'", "NaN")


# ------------------------------------------------------------------ mmocap summaries


def run_folder_with(tmp_path, summary: str) -> Path:
    run = tmp_path / "runs" / "r1"
    run.mkdir(parents=True)
    (run / "summary.json").write_text(summary)
    return tmp_path / "runs"


@pytest.mark.parametrize(
    ("summary", "culprits"),
    [
        ('{"optimizer": "cma', ("not valid JSON",)),
        (
            json.dumps(
                {
                    **json.loads((Path(__file__).parents[1] / "golden" / "data" / "summary.json").read_text()),
                    "optimizer": "cmaes",
                    "mean_marker_error_mm": "low",
                }
            ),
            ("mean_marker_error_mm", "'low'"),
        ),
    ],
    ids=["truncated", "text-error"],
)
def test_summaries_names_a_broken_summary(tmp_path, summary, culprits):
    folder = run_folder_with(tmp_path, summary)
    assert_clean_error(mmocap("summaries", folder), str(folder / "r1" / "summary.json"), *culprits)


# ------------------------------------------------------------------ mmocap paper: runs.csv


def sweep_with(tmp_path, change=lambda runs: runs, scale: float = 1.0, name: str = "sweep") -> Path:
    """A sweep folder whose runs.csv holds 3 algorithms x 2 sequences x 2 seeds at 39 DOF and
    150 evaluations, for 2 mesh sizes x 2 backends, then ``change``d."""
    rows = []
    for k, optimizer in enumerate(("cmaes", "de", "pso")):
        for sequence in ("S1_walking", "S1_boxing"):
            for seed in (0, 1):
                for vertices in (1000, 3000):
                    for backend, speed in (("numpy", 1.0), ("opencl", 0.1)):
                        rows.append(
                            dict(
                                run_id=f"r{len(rows)}",
                                sequence=sequence,
                                seed=seed,
                                optimizer=optimizer,
                                strategy="holistic",
                                algorithm=f"{optimizer}-holistic",
                                dof=39,
                                evaluations=150,
                                vertices=vertices,
                                backend=backend,
                                mean_marker_error_mm=scale * (10 + k + seed / 10 + vertices / 1e4),
                                mean_best_fitness=0.1 + k / 100,
                                seconds_per_frame=scale * (speed * vertices / 1000),
                            )
                        )
    folder = tmp_path / name
    folder.mkdir()
    change(pd.DataFrame(rows)).to_csv(folder / "runs.csv", index=False)
    return folder


BAD_RUNS = {
    "missing-columns": ("table4", lambda r: r.drop(columns=["optimizer", "dof"]), ("'optimizer', 'dof'",)),
    "text-dof": (
        "table4",
        lambda r: r.astype({"dof": object}).assign(dof=["lots"] + [39] * (len(r) - 1)),
        ("'dof'", "whole numbers", "'lots'", "data row 1"),
    ),
    "empty-evaluations": (
        "table4",
        lambda r: r.assign(evaluations=[np.nan] + [150] * (len(r) - 1)),
        ("'evaluations'", "1 empty cell", "data row 1"),
    ),
    "empty-optimizer": (
        "table4",
        lambda r: r.assign(optimizer=r.optimizer.where(r.index != 5, None)),
        ("'optimizer'", "1 empty cell", "data row 6"),
    ),
    "fig4-empty-backend": (
        "fig4",
        lambda r: r.assign(backend=r.backend.where(r.index != 7, None)),
        ("'backend'", "1 empty cell", "data row 8"),
    ),
    "fig4-text-time": (
        "fig4",
        lambda r: r.astype({"seconds_per_frame": object}).assign(
            seconds_per_frame=["slow"] + list(r.seconds_per_frame[1:])
        ),
        ("'seconds_per_frame'", "'slow'"),
    ),
}


@pytest.mark.parametrize("case", list(BAD_RUNS))
def test_paper_names_the_bad_column_of_runs_csv(tmp_path, case):
    name, change, culprits = BAD_RUNS[case]
    folder = sweep_with(tmp_path, change)
    outcome = mmocap("paper", name, folder, "--out", tmp_path / "out")
    assert_clean_error(outcome, str(folder / "runs.csv"), *culprits)


def test_paper_names_a_bad_frame_number_in_frames_csv(tmp_path):
    folder = sweep_with(tmp_path)
    pd.DataFrame({"run_id": ["r0", "r0"], "frame": [0, 0.5], "marker_error_mm": [10.0, 11.0]}).to_csv(
        folder / "frames.csv", index=False
    )
    outcome = mmocap("paper", "fig10", folder, "--out", tmp_path / "out")
    assert_clean_error(outcome, str(folder / "frames.csv"), "'frame'", "0.5", "data row 2")


def test_fig4_near_the_float_limit_gives_the_front_of_moderate_values(tmp_path):
    fronts = []
    for scale, name in ((1.0, "moderate"), (1e307, "huge")):
        folder = sweep_with(tmp_path, scale=scale, name=name)
        outcome = mmocap("paper", "fig4", folder, "--out", tmp_path / name / "out")
        assert outcome.code == 0, outcome
        front = pd.read_csv(tmp_path / name / "out" / "tables" / "fig4.csv", comment="#")
        assert np.isfinite(front[["seconds_per_frame", "mean_marker_error_mm"]].to_numpy()).all()
        fronts.append(front)
    moderate, huge = fronts
    assert huge[["vertices", "evaluations", "backend", "runs", "pareto"]].equals(
        moderate[["vertices", "evaluations", "backend", "runs", "pareto"]]
    )
    np.testing.assert_allclose(huge["mean_marker_error_mm"] / 1e307, moderate["mean_marker_error_mm"], rtol=1e-12)


# ------------------------------------------------------------------ mmocap foreground-quality: its options


@pytest.mark.parametrize(
    ("options", "culprits"),
    [
        (["--methods", "horprasert,,knn"], ("--methods", "empty name")),
        (["--csv", "."], ("--csv", "is a folder")),
    ],
    ids=["empty-method-name", "csv-is-a-folder"],
)
def test_foreground_quality_names_a_bad_option_before_any_work(tmp_path, options, culprits):
    assert_clean_error(mmocap("foreground-quality", *options, cwd=tmp_path), *culprits)


def test_foreground_quality_names_a_silhouette_of_the_wrong_size(sequence_copy, tmp_path):
    import cv2

    path = sequence_copy / "silhouettes" / "C1" / "000001.png"
    cv2.imwrite(str(path), np.zeros((60, 80), np.uint8))
    outcome = mmocap(
        "foreground-quality",
        "--methods",
        "horprasert",
        "--csv",
        tmp_path / "q.csv",
        "--md",
        tmp_path / "q.md",
        "dataset=folder",
        f"dataset.root={sequence_copy}",
        "dataset.subject=S1",
        "progress=false",
    )
    assert_clean_error(outcome, "camera C1", "frame 1", "80x60", "160x120")
    assert not (tmp_path / "q.csv").exists()
