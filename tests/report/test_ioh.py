"""Convergence traces of real tiny runs, exported in the IOHprofiler format: the files are read
back by a plain parser written here and compared with the runs' own numbers, and with what the
``ioh`` package's Analyzer logger writes for the same traces."""

from __future__ import annotations

import csv
import json
import re
import shutil

import numpy as np
import pytest

from mmocap.config import compose
from mmocap.report.ioh import find_runs, write_ioh
from mmocap.run_folder import TRACES
from tests.helpers import Outcome, assert_clean_error, run_cli

FRAMES, BUDGET = 2, 30
#: run folder -> (overrides, algorithm, dimension)
RUNS = {
    "0": (["seed=0"], "cmaes-holistic", 39),
    "1": (["seed=1", "body.dof=28"], "cmaes-holistic", 28),
    "2": (["seed=0", "optimizer=pso"], "pso-holistic", 39),
}


@pytest.fixture(scope="module")
def sweep(tiny_sequence, tmp_path_factory):
    """A folder of three finished runs of the tiny sequence (two algorithms, two dimensions)."""
    from mmocap.pipeline import run

    folder = tmp_path_factory.mktemp("sweep")
    for name, (overrides, _, _) in RUNS.items():
        run(
            compose(
                [
                    "dataset=folder",
                    f"dataset.root={tiny_sequence}",
                    "evaluator=numpy",
                    "body.vertices=1000",
                    f"tracking.evaluations={BUDGET}",
                    f"tracking.frames={FRAMES}",
                    "recovery.enabled=false",
                    "overlays=0",
                    "progress=false",
                    "foreground_cache=null",
                    *overrides,
                ]
            ),
            folder / name,
        )
    return folder


@pytest.fixture(scope="module")
def exported(sweep):
    out = sweep / "ioh"
    write_ioh(find_runs(sweep), out)
    return out


def frames_table(run_folder) -> dict[int, tuple[int, float]]:
    """frames.csv: frame -> (evaluations, fitness)."""
    with open(run_folder / "frames.csv", newline="") as f:
        return {int(row["frame"]): (int(row["evaluations"]), float(row["fitness"])) for row in csv.DictReader(f)}


def parse_traces(path) -> dict[int, list[tuple[int, float]]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["frame", "evaluations", "best_fitness"]
    traces: dict[int, list[tuple[int, float]]] = {}
    for frame, evaluations, fitness in rows[1:]:
        traces.setdefault(int(frame), []).append((int(evaluations), float(fitness)))
    return traces


def parse_dat(path) -> list[np.ndarray]:
    """The runs of an IOHprofiler .dat file: (k, 2) (evaluations, raw_y) each, split at the
    header lines."""
    runs = []
    for line in path.read_text().splitlines():
        if line == "evaluations raw_y":
            runs.append([])
        else:
            evaluations, y = line.split(" ")
            runs[-1].append((int(evaluations), float(y)))
    return [np.array(run) for run in runs]


def read_export(folder) -> dict[str, tuple[dict, dict[int, list[np.ndarray]]]]:
    """Every meta-data file below ``folder`` (path relative to it -> (its JSON, dimension ->
    runs of the .dat file its scenario names))."""
    found = {}
    for path in sorted(folder.rglob("*.json")):
        meta = json.loads(path.read_text())
        found[str(path.relative_to(folder))] = (
            meta,
            {s["dimension"]: parse_dat(path.parent / s["path"]) for s in meta["scenarios"]},
        )
    return found


def test_a_run_writes_each_frames_trace_ending_at_its_evaluations_and_fitness(sweep):
    for name in RUNS:
        traces, frames = parse_traces(sweep / name / TRACES), frames_table(sweep / name)
        assert sorted(traces) == sorted(frames) == list(range(FRAMES))
        for frame, trace in traces.items():
            evaluations, fitness = np.array(trace).T
            assert evaluations[0] == 1
            assert np.all(np.diff(evaluations) > 0)
            assert np.all(np.diff(fitness) <= 0)
            assert evaluations[-1] == frames[frame][0] == BUDGET
            assert fitness[-1] == pytest.approx(frames[frame][1], abs=5e-7)  # frames.csv keeps 6 decimals


def test_the_export_holds_every_frame_of_every_run_under_its_algorithm_function_and_dimension(sweep, exported):
    files = read_export(exported)
    assert sorted(files) == [
        "cmaes-holistic/IOHprofiler_f1_S1_walking.json",
        "pso-holistic/IOHprofiler_f1_S1_walking.json",
    ]
    for name, (_, algorithm, dimension) in RUNS.items():
        meta, dat = files[f"{algorithm}/IOHprofiler_f1_S1_walking.json"]
        assert (meta["function_id"], meta["function_name"], meta["maximization"]) == (1, "S1_walking", False)
        assert meta["algorithm"]["name"] == algorithm
        assert meta["attributes"] == ["evaluations", "raw_y"]
        assert f"{BUDGET} evaluations per frame" in meta["algorithm"]["info"]
        scenario = next(s for s in meta["scenarios"] if s["dimension"] == dimension)
        assert scenario["path"] == f"data_f1_S1_walking/IOHprofiler_f1_DIM{dimension}.dat"
        assert len(scenario["runs"]) == len(dat[dimension]) == FRAMES  # one run folder per algorithm and dimension
        traces, frames = parse_traces(sweep / name / TRACES), frames_table(sweep / name)
        for frame, entry, rows in zip(range(FRAMES), scenario["runs"], dat[dimension]):
            np.testing.assert_array_equal(rows, np.array(traces[frame]))
            assert entry["instance"] == frame + 1
            assert entry["evals"] == frames[frame][0]
            assert entry["best"]["y"] == rows[-1, 1] == pytest.approx(frames[frame][1], abs=5e-7)
            assert entry["best"]["evals"] == rows[np.argmax(rows[:, 1] == rows[-1, 1]), 0]
    assert [s["dimension"] for s in files["cmaes-holistic/IOHprofiler_f1_S1_walking.json"][0]["scenarios"]] == [28, 39]


def without_ids(text: str) -> str:
    """A path with its function ids replaced by ``#`` (ioh numbers a wrapped problem itself)."""
    return re.sub(r"_f\d+", "_f#", text)


def test_the_export_matches_what_iohs_analyzer_logger_writes_for_the_same_traces(sweep, exported, tmp_path):
    """Every frame's trace replayed through an ioh problem (each evaluation returns the best
    fitness so far) and logged by ioh's Analyzer: the same files, runs and values."""
    ioh = pytest.importorskip("ioh")
    runs = find_runs(sweep)
    for algorithm in sorted({run.algorithm for run in runs}):
        logger = ioh.logger.Analyzer(root=str(tmp_path), folder_name=algorithm, algorithm_name=algorithm)
        for dimension in sorted({run.dimension for run in runs}):
            for run in (r for r in runs if r.algorithm == algorithm and r.dimension == dimension):
                for frame, trace in run.traces.items():
                    best = trace[np.searchsorted(trace[:, 0], np.arange(1, trace[-1, 0] + 1), side="right") - 1, 1]
                    values = iter(best)
                    problem = ioh.wrap_problem(
                        lambda x, values=values: float(next(values)),
                        name=run.function,
                        dimension=dimension,
                        instance=frame + 1,
                        lb=-1.0,
                        ub=1.0,
                    )
                    problem.attach_logger(logger)
                    for _ in best:
                        problem(np.zeros(dimension))
                    problem.reset()
        logger.close()
    ours, theirs = read_export(exported), read_export(tmp_path)
    assert sorted(map(without_ids, ours)) == sorted(map(without_ids, theirs))
    theirs = {without_ids(path): content for path, content in theirs.items()}
    for path, (meta, dat) in ours.items():
        reference, reference_dat = theirs[without_ids(path)]
        assert meta["algorithm"]["name"] == reference["algorithm"]["name"]
        for key in ("function_name", "maximization", "attributes"):
            assert meta[key] == reference[key]
        assert [without_ids(s["path"]) for s in meta["scenarios"]] == [
            without_ids(s["path"]) for s in reference["scenarios"]
        ]
        for scenario, expected in zip(meta["scenarios"], reference["scenarios"]):
            assert [(r["instance"], r["evals"], r["best"]["evals"]) for r in scenario["runs"]] == [
                (r["instance"], r["evals"], r["best"]["evals"]) for r in expected["runs"]
            ]
            np.testing.assert_allclose(
                [r["best"]["y"] for r in scenario["runs"]], [r["best"]["y"] for r in expected["runs"]], atol=1e-12
            )
        for dimension, runs_dat in dat.items():
            assert len(runs_dat) == len(reference_dat[dimension])
            for rows, expected in zip(runs_dat, reference_dat[dimension]):
                np.testing.assert_array_equal(rows[:, 0], expected[:, 0])
                np.testing.assert_allclose(rows[:, 1], expected[:, 1], atol=1e-10)  # ioh writes 10 decimals


def test_the_command_writes_into_the_folder_and_replaces_an_earlier_export(sweep, tmp_path, capsys):
    out = tmp_path / "ioh"
    stale = out / "de-holistic" / "data_f3_S2_boxing" / "IOHprofiler_f3_DIM39.dat"
    stale.parent.mkdir(parents=True)
    stale.write_text("evaluations raw_y\n1 0.5\n")
    (stale.parents[1] / "IOHprofiler_f3_S2_boxing.json").write_text("{}")
    (out / "notes.txt").write_text("mine")
    assert run_cli("ioh", sweep / "0", "--out", out) == 0
    assert "1 run(s), 2 frame(s), 1 algorithm(s), 1 meta-data file(s)" in capsys.readouterr().out
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()) == [
        "cmaes-holistic/IOHprofiler_f1_S1_walking.json",
        "cmaes-holistic/data_f1_S1_walking/IOHprofiler_f1_DIM39.dat",
        "notes.txt",
    ]
    assert not (out / "de-holistic").exists()


def replace_line(path, number: int, text: str) -> None:
    lines = path.read_text().splitlines()
    lines[number - 1] = text
    path.write_text("\n".join(lines) + "\n")


def drop_key(path, key: str) -> None:
    summary = json.loads(path.read_text())
    del summary[key]
    path.write_text(json.dumps(summary))


#: case -> (damage done to a copy of a run folder, words the error names)
BAD_RUNS = {
    "no-traces": (lambda run: (run / TRACES).unlink(), [TRACES, "missing", "track it again"]),
    "bad-header": (lambda run: replace_line(run / TRACES, 1, "frame,evals,fitness"), [TRACES, "header"]),
    "bad-row": (lambda run: replace_line(run / TRACES, 2, "0,1"), [TRACES, "line 2"]),
    "not-from-1": (lambda run: replace_line(run / TRACES, 2, "0,2,0.5"), [TRACES, "line 2", "not 1"]),
    "fitness-rises": (lambda run: replace_line(run / TRACES, 3, "0,29,0.99"), [TRACES, "line 3", "must not"]),
    "frame-missing": (
        lambda run: (run / TRACES).write_text("frame,evaluations,best_fitness\n0,1,0.5\n"),
        [TRACES, "missing [1]"],
    ),
    "no-dof": (lambda run: drop_key(run / "summary.json", "dof"), ["summary.json", "dof"]),
    "summary-not-json": (lambda run: (run / "summary.json").write_text("{"), ["summary.json", "not valid JSON"]),
}


@pytest.mark.parametrize("case", list(BAD_RUNS))
def test_a_bad_run_folder_is_one_clear_line(case, sweep, tmp_path, capsys):
    run = tmp_path / "run"
    shutil.copytree(sweep / "0", run, ignore=shutil.ignore_patterns("records"))
    damage, culprits = BAD_RUNS[case]
    damage(run)
    code = run_cli("ioh", tmp_path, "--out", tmp_path / "ioh")
    captured = capsys.readouterr()
    assert_clean_error(Outcome(["ioh", str(tmp_path)], code, captured.out, captured.err), *culprits)
    assert not (tmp_path / "ioh").exists()


def test_a_folder_without_runs_is_one_clear_line(tmp_path, capsys):
    for folder, culprit in ((tmp_path, "no finished run"), (tmp_path / "nope", "no such folder")):
        code = run_cli("ioh", folder)
        captured = capsys.readouterr()
        assert_clean_error(Outcome(["ioh", str(folder)], code, captured.out, captured.err), culprit, str(folder))
