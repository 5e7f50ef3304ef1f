"""Multirun sweeps end to end: launchers, resuming a killed sweep, progress, bad sweeps, and
the pin: code, config files and plugins that change under a sweep, and paper experiments
from a checkout with uncommitted changes."""

import fcntl
import hashlib
import importlib.metadata
import importlib.resources
import importlib.util
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd
import pytest

from mmocap import config as mmocap_config
from mmocap import pin, pipeline
from mmocap.analysis.results import SCHEMA
from mmocap.sweep import unfinished_jobs
from tests.helpers import assert_clean_error, mmocap, mmocap_in_process, overrides


def sweep_args(data_root, sweep_dir, **extra):
    """A multirun over the session's tiny sequence into ``sweep_dir``."""
    settings = {"overlays": 0, "tracking.evaluations": 100, "hydra.sweep.dir": str(sweep_dir), **extra}
    return ["-m", *overrides(data_root, **settings)]


def records(sweep_dir):
    folder = sweep_dir / "records"
    return sorted(folder.glob("*.json")) if folder.is_dir() else []


def test_joblib_sweep_records_every_run_once_with_provenance(tiny_sequence, tmp_path):
    sweep = tmp_path / "sweep"
    out = mmocap(*sweep_args(tiny_sequence.parent, sweep, seed="0,1"), cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "JoblibLauncher" in json.loads((sweep / "sweep.json").read_text())["launcher"]
    assert len(records(sweep)) == 2
    runs = pd.read_csv(sweep / "runs.csv")
    frames = pd.read_csv(sweep / "frames.csv")
    assert sorted(runs["seed"]) == [0, 1]
    assert set(runs["algorithm"]) == {"cmaes-holistic"}
    assert len(frames) == 2 * 2
    assert set(frames["run_id"]) == set(runs["run_id"])
    assert (runs["evaluation_seconds_per_frame"] <= runs["seconds_per_frame"]).all()
    info = json.loads((sweep / "sweep.json").read_text())
    assert info["jobs"] == 2
    assert "seed=0,1" in info["overrides"]
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=Path(__file__).parent, capture_output=True, text=True
    ).stdout.strip()
    assert info["provenance"]["git_commit"] == head  # run from this checkout: its commit
    assert info["provenance"]["versions"]["numpy"] == importlib.metadata.version("numpy")
    shipped = Path(str(importlib.resources.files("mmocap.conf")))
    config_digest = hashlib.sha256((shipped / "config.yaml").read_bytes()).hexdigest()
    assert info["pin"]["configs"]["pkg://mmocap.conf"]["config.yaml"] == config_digest
    assert (
        info["pin"]["code"]["mmocap/sweep.py"]
        == hashlib.sha256(Path(pin.__file__).with_name("sweep.py").read_bytes()).hexdigest()
    )
    assert info["pin"]["plugins"]["mmocap"] == importlib.metadata.version("mmocap")
    assert info["pin"]["packages"] == info["provenance"]["versions"]
    assert info["dirty_files"] == pin.dirty_files()
    assert info["allow_dirty"] is False
    record = json.loads(records(sweep)[0].read_text())
    assert record["config"]["tracking"]["evaluations"] == 100
    assert record["provenance"]["host"]
    log = out.stdout + out.stderr
    assert "sweep: 2/2 runs done (0 found in the store)" in log
    assert log.count("sweep: ") == 2

    again = mmocap(*sweep_args(tiny_sequence.parent, sweep, seed="0,1,2"), cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert (again.stdout + again.stderr).count("already finished") == 2
    assert "sweep: 3/3 runs done (2 found in the store)" in again.stdout + again.stderr
    assert len(pd.read_csv(sweep / "runs.csv")) == 3
    resumed = json.loads((sweep / "sweep.json").read_text())
    assert resumed["session"] != info["session"]
    assert resumed["pin"] == info["pin"]  # taken when the sweep first started, kept


@pytest.mark.slow
def test_a_killed_sweep_resumes_without_losing_or_repeating_runs(tiny_sequence, tmp_path):
    """SIGKILL the whole sweep (launcher and workers) once its first record is written."""
    sweep = tmp_path / "sweep"
    args = sweep_args(
        tiny_sequence.parent, sweep, seed="range(6)", **{"tracking.evaluations": 600, "body.vertices": 13695}
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "mmocap", *args],
        cwd=tmp_path,
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 300
    while not records(sweep) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = {p.name: p.read_bytes() for p in records(sweep)}
    assert 1 <= len(finished) < 6, "the sweep was not killed midway"

    out = mmocap(*args, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    log = out.stdout + out.stderr
    assert log.count("already finished") == len(finished)
    assert f"sweep: 6/6 runs done ({len(finished)} found in the store)" in log
    after = {p.name: p.read_bytes() for p in records(sweep)}
    assert len(after) == 6
    assert all(after[name] == data for name, data in finished.items())
    runs = pd.read_csv(sweep / "runs.csv")
    assert sorted(runs["seed"]) == list(range(6))
    assert runs["run_id"].is_unique
    assert len(pd.read_csv(sweep / "frames.csv")) == 6 * 2
    assert not list(sweep.rglob("*.tmp"))


@pytest.mark.slow
@pytest.mark.skipif(
    importlib.util.find_spec("hydra_plugins.hydra_submitit_launcher") is None,
    reason="hydra-submitit-launcher not installed (pip install mmocap[slurm])",
)
def test_submitit_local_launcher(tiny_sequence, tmp_path):
    sweep = tmp_path / "sweep"
    out = mmocap(
        *sweep_args(tiny_sequence.parent, sweep, seed="0,1"),
        "hydra/launcher=submitit_local",
        "hydra.launcher.timeout_min=5",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    assert "hydra_submitit_launcher" in json.loads((sweep / "sweep.json").read_text())["launcher"]
    assert sorted(pd.read_csv(sweep / "runs.csv")["seed"]) == [0, 1]


@pytest.mark.slow
def test_an_experiment_runs_on_the_tiny_sequence(tiny_sequence, tmp_path):
    """Fig. 10 at the smoke scale: four holistic algorithms, one run each with the paper's
    settings and one with the tuned ones."""
    sweep = tmp_path / "fig10"
    out = mmocap(
        "-m",
        "+experiment=fig10",
        "scale=smoke",
        "+allow_dirty=true",  # a paper experiment, run from a working tree that may have changes
        *overrides(tiny_sequence.parent),
        "overlays=0",
        f"hydra.sweep.dir={sweep}",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    runs = pd.read_csv(sweep / "runs.csv")
    algorithms = ["apf-holistic", "cmaes-holistic", "de-holistic", "pso-holistic"]
    assert sorted(runs["algorithm"]) == sorted(2 * algorithms)
    assert sorted(runs["settings"]) == 4 * ["paper"] + 4 * ["tuned"]
    # the command line (tracking.evaluations=300, tracking.frames=2) wins over the experiment
    assert set(runs["evaluations"]) == {300}
    assert set(runs["frames"]) == {2}


BAD_SWEEPS = [
    (["optimizer=cmaes,nope"], "optimizer/nope"),
    (["optimizer.name=cmaes,nope"], "unknown optimizer 'nope'; installed optimizers:"),
    (["evaluator=numpy,multiprocessing"], "evaluator=multiprocessing cannot start its workers"),
    (["+experiment=table4", "scale=huge"], "scale/huge"),
    (["+experiment=table99"], "experiment/table99"),
]


@pytest.mark.parametrize(("extra", "message"), BAD_SWEEPS, ids=[" ".join(b[0]) for b in BAD_SWEEPS])
def test_a_bad_sweep_fails_before_any_job(tiny_sequence, tmp_path, extra, message):
    sweep = tmp_path / "sweep"
    out = mmocap(*sweep_args(tiny_sequence.parent, sweep), *extra, cwd=tmp_path)
    assert out.returncode != 0
    assert message in out.stderr
    assert "Traceback" not in out.stderr
    assert not records(sweep)
    assert not (sweep / "0").exists()


# conf/hydra/launcher/<name>, the plugin it extends, its launcher class, the extra installing it
LAUNCHERS = [
    ("local", "hydra_joblib_launcher", "JoblibLauncher", None),
    ("slurm", "hydra_submitit_launcher", "SlurmLauncher", "slurm"),
    ("ray_cpu", "hydra_ray_launcher", "RayLauncher", "ray"),
]


@pytest.mark.parametrize(("name", "plugin", "target", "extra"), LAUNCHERS, ids=[launcher[0] for launcher in LAUNCHERS])
def test_launcher_configs_compose(name, plugin, target, extra):
    if importlib.util.find_spec(f"hydra_plugins.{plugin}") is None:
        pytest.skip(f"{plugin} not installed (pip install mmocap[{extra}])")
    cfg = mmocap_config.compose(["+experiment=table4", f"hydra/launcher={name}"], return_hydra_config=True)
    assert cfg.hydra.launcher._target_.endswith(target)


def test_two_sweeps_into_one_store_at_once_run_each_job_once(tiny_sequence, tmp_path):
    """Two sweeps at once, over overlapping seeds in the same order, into one results.store:
    every run is recorded whole, each by exactly one of them; the other one waits for it (its
    claim in the store) or finds it, and no claim is left."""
    store = tmp_path / "store"

    def sweep(name: str, seeds: str):
        extra = {"results.store": store, "evaluator": "numpy", "hydra.launcher.n_jobs": 1}
        return mmocap(*sweep_args(tiny_sequence.parent, tmp_path / name, seed=seeds, **extra), cwd=tmp_path)

    with ThreadPoolExecutor(2) as pool:
        outcomes = list(pool.map(sweep, ["a", "b"], ["0,1,2", "0,1,2,3"]))
    assert all(out.returncode == 0 for out in outcomes), "\n".join(map(str, outcomes))
    log = "".join(out.stdout + out.stderr for out in outcomes)
    ran = re.findall(r"run (\w{16}) recorded in", log)
    found = re.findall(r"run (\w{16}) already finished", log)
    assert sorted(ran) == sorted(set(ran)), f"a run was run twice: {ran}"
    assert len(ran) == 4
    assert len(found) == 3
    counted = [line["ran"] for name in "ab" for line in map(json.loads, (tmp_path / name / "progress.jsonl").open())]
    assert sum(counted) == 4, f"the progress lines count {sum(counted)} runs as run, not the 4 that were"
    by_seed = {}
    for path in records(store):
        record = json.loads(path.read_text())
        assert record["summary"]["frames"] == 2
        assert record["run_id"] == path.stem
        by_seed[record["seed"]] = path.stem
    assert sorted(by_seed) == [0, 1, 2, 3]
    assert sorted(by_seed.values()) == sorted(ran)
    assert list(store.glob("records/.*")) == []
    assert json.loads((store / "store.json").read_text()) == {"schema": SCHEMA}


def test_unfinished_jobs_are_those_of_this_session_without_a_completed_line(tmp_path):
    jobs = [["seed=0", "evaluator=numpy"], ["seed=1", "evaluator=numpy"], ["seed=2", "evaluator=numpy"]]
    assert unfinished_jobs(tmp_path, jobs) == []  # no sweep.json: no session to speak of
    (tmp_path / "sweep.json").write_text(json.dumps({"session": "now"}))
    assert unfinished_jobs(tmp_path, jobs) == ["#0 (seed=0)", "#1 (seed=1)", "#2 (seed=2)"]  # no job has ended
    lines = [
        {"session": "now", "job": 0, "status": "COMPLETED", "ran": True},
        {"session": "before", "job": 1, "status": "COMPLETED", "ran": True},  # an earlier session's
        {"session": "now", "job": 2, "status": "FAILED", "ran": False},
    ]
    text = "".join(json.dumps(line) + "\n" for line in lines) + '{"session": "now", "job": 1, "sta'  # torn
    (tmp_path / "progress.jsonl").write_text(text)
    assert unfinished_jobs(tmp_path, jobs) == ["#1 (seed=1)", "#2 (seed=2)"]
    assert unfinished_jobs(tmp_path, [["seed=0"]]) == []
    (tmp_path / "progress.jsonl").unlink()
    assert unfinished_jobs(tmp_path, [["seed=0", "evaluator=numpy"]]) == ["#0 (seed=0 evaluator=numpy)"]  # alone
    assert unfinished_jobs(tmp_path, [[]]) == ["#0 (no overrides)"]


def test_a_sweep_that_stops_on_a_failed_job_names_the_jobs_left(tiny_sequence, tmp_path):
    """Job 1's run folder is held by another process: the job stops, and with it the sweep
    (its jobs run in turn here); the line names the jobs that did not finish."""
    sweep = tmp_path / "sweep"
    (sweep / "1").mkdir(parents=True)
    with (sweep / "1" / ".run.lock").open("w") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        out = mmocap(
            *sweep_args(tiny_sequence.parent, sweep, seed="0,1,2", **{"hydra.launcher.n_jobs": 1}), cwd=tmp_path
        )
    assert out.returncode == 2, out.stderr
    assert "is in use by another run" in out.stderr
    line = (
        f"mmocap: error: 2 of 3 sweep jobs did not finish: #1 (seed=1), #2 (seed=2); finished runs are kept in {sweep}"
    )
    assert line in out.stderr
    assert "Traceback" not in out.stderr
    assert len(records(sweep)) == 1


# --- the pin: what changes under a sweep after its first job -----------------------------------


def in_process_sweep(data_root: Path, sweep: Path, *extra: str, config_dir: Path | None = None) -> list[str]:
    """A quick multirun of the tiny sequence whose jobs run in this process, one after another,
    with the user's config folder ``config_dir`` (``--config-dir``) if given."""
    settings = {"evaluator": "numpy", "body.vertices": 1000, "tracking.evaluations": 60}
    options = ["--config-dir", str(config_dir)] if config_dir else []
    return [*options, *sweep_args(data_root, sweep, **settings), "hydra/launcher=basic", *extra]


# each: (tmp_path, monkeypatch) -> (the user's config folder or None, overrides, the change, its undoing,
# the words naming it)


def changed_config(tmp_path, monkeypatch):
    """The user's experiment (``--config-dir``) gets another budget."""
    mine = tmp_path / "myconf" / "experiment" / "mine.yaml"
    mine.parent.mkdir(parents=True)
    mine.write_text("# @package _global_\ntracking:\n  evaluations: 60\n")
    before = mine.read_text()
    return (
        tmp_path / "myconf",
        ["+experiment=mine"],
        lambda: mine.write_text(before.replace("60", "70")),
        lambda: mine.write_text(before),
        "myconf/experiment/mine.yaml changed since",
    )


def changed_code(tmp_path, monkeypatch):
    """A module of the package the jobs run is edited."""
    package = tmp_path / "installed" / "mmocap"
    shutil.copytree(pin.PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(pin, "PACKAGE", package)
    module = package / "pipeline.py"
    before = module.read_text()
    return (
        None,
        [],
        lambda: module.write_text(before + "# edited\n"),
        lambda: module.write_text(before),
        "mmocap/pipeline.py changed",
    )


def upgraded_plugin(tmp_path, monkeypatch):
    """A plugin registering an optimiser is upgraded from 1.0 to 2.0."""
    site = tmp_path / "site"
    site.mkdir()
    monkeypatch.syspath_prepend(str(site))

    def install(version: str) -> None:
        for old in site.glob("*.dist-info"):
            shutil.rmtree(old)
        info = site / f"mmocap_fake-{version}.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: mmocap-fake\nVersion: {version}\n")
        (info / "entry_points.txt").write_text("[mmocap.optimizers]\nfake = mmocap.optimizers.cmaes:CMAES\n")

    install("1.0")
    return None, [], lambda: install("2.0"), lambda: install("1.0"), "plugin mmocap-fake (1.0, now 2.0) changed"


CHANGES = [changed_config, changed_code, upgraded_plugin]


@pytest.mark.parametrize("change", CHANGES, ids=[c.__name__ for c in CHANGES])
def test_a_change_after_the_first_job_stops_the_sweep_and_the_same_command_resumes_once_undone(
    tiny_sequence, tmp_path, monkeypatch, change
):
    config_dir, experiment, make_change, undo, named = change(tmp_path, monkeypatch)
    sweep = tmp_path / "sweep"
    args = in_process_sweep(tiny_sequence.parent, sweep, "seed=0,1,2", *experiment, config_dir=config_dir)
    run = pipeline.run

    def run_then_change(cfg, output_dir):
        summary = run(cfg, output_dir)
        make_change()
        return summary

    monkeypatch.setattr(pipeline, "run", run_then_change)
    stopped = mmocap_in_process(*args, cwd=tmp_path)
    line = assert_clean_error(stopped, named, f"the sweep in {sweep} started", "hydra.sweep.dir=")
    assert "undo the change and run the same command" in line
    assert len(records(sweep)) == 1, "the refused job wrote a record"
    assert not (sweep / "2").exists(), "the sweep went on after a job refused"

    monkeypatch.setattr(pipeline, "run", run)
    undo()
    resumed = mmocap_in_process(*args, cwd=tmp_path)
    assert resumed.code == 0, resumed
    assert "sweep: 3/3 runs done (1 found in the store)" in resumed.stdout + resumed.stderr
    assert len(records(sweep)) == 3


# --- paper experiments and the checkout's uncommitted changes --------------------------------


def test_every_paper_experiment_requires_a_clean_checkout_and_the_demo_does_not():
    for name in mmocap_config.options("experiment"):
        required = mmocap_config.compose([f"+experiment={name}"]).pin.require_clean
        assert required is (name != "demo"), name
    assert mmocap_config.compose([]).pin.require_clean is False


def test_a_sweep_requiring_a_clean_checkout_refuses_a_dirty_one_unless_allowed(tiny_sequence, tmp_path, monkeypatch):
    monkeypatch.setattr(pin, "dirty_files", lambda: ["mmocap/pipeline.py"])
    sweep = tmp_path / "sweep"
    args = in_process_sweep(tiny_sequence.parent, sweep, "seed=0", "pin.require_clean=true")
    refused = mmocap_in_process(*args, cwd=tmp_path)
    assert_clean_error(refused, "uncommitted changes (mmocap/pipeline.py)", "+allow_dirty=true")
    assert not (sweep / "sweep.json").exists()
    assert not (sweep / "0").exists()

    allowed = mmocap_in_process(*args, "+allow_dirty=true", cwd=tmp_path)
    assert allowed.code == 0, allowed
    info = json.loads((sweep / "sweep.json").read_text())
    assert (info["allow_dirty"], info["dirty_files"]) == (True, ["mmocap/pipeline.py"])
    (record,) = records(sweep)
    assert json.loads(record.read_text())["config"]["allow_dirty"] is True


@pytest.mark.parametrize("dirty", [[], None], ids=["clean checkout", "installed wheel"])
def test_a_sweep_requiring_a_clean_checkout_runs_from_a_clean_one_or_a_wheel(
    tiny_sequence, tmp_path, monkeypatch, dirty
):
    monkeypatch.setattr(pin, "dirty_files", lambda: dirty)
    sweep = tmp_path / "sweep"
    outcome = mmocap_in_process(*in_process_sweep(tiny_sequence.parent, sweep, "seed=0", "pin.require_clean=true"))
    assert outcome.code == 0, outcome
    info = json.loads((sweep / "sweep.json").read_text())
    assert (info["allow_dirty"], info["dirty_files"]) == (False, dirty)


def test_a_single_run_requiring_a_clean_checkout_refuses_a_dirty_one(tiny_sequence, tmp_path, monkeypatch):
    monkeypatch.setattr(pin, "dirty_files", lambda: ["conf/config.yaml"])
    run = [*overrides(tiny_sequence.parent), f"hydra.run.dir={tmp_path / 'run'}", "pin.require_clean=true"]
    assert_clean_error(mmocap_in_process(*run), "uncommitted changes (conf/config.yaml)", "+allow_dirty=true")
    assert not (tmp_path / "run" / "summary.json").exists()


@pytest.mark.parametrize("value", ["maybe", "2"])
def test_allow_dirty_is_true_or_false(tiny_sequence, tmp_path, value):
    sweep = tmp_path / "sweep"
    outcome = mmocap_in_process(
        *in_process_sweep(tiny_sequence.parent, sweep, "pin.require_clean=true", f"+allow_dirty={value}")
    )
    assert_clean_error(outcome, "allow_dirty")
