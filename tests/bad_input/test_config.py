"""Bad config values: one line naming the key, exit 2, before any data is rendered or read;
in a sweep, before the first job starts."""

import pytest

from tests.helpers import assert_clean_error
from tests.helpers import mmocap_in_process as mmocap

CASES = [
    ("seed=abc", "seed"),
    ("seed=-1", "seed"),
    ("seed=1.5", "seed"),
    ("tracking.evaluations=150.7", "tracking.evaluations"),  # was truncated to 150 silently
    ("tracking.evaluations=lots", "tracking.evaluations"),
    ("tracking.evaluations=0", "tracking.evaluations"),
    ("tracking.frames=0", "tracking.frames"),
    ("overlays=-1", "overlays"),
    ("progress=maybe", "progress"),
    ("dataset.width=wide", "dataset.width"),
    ("dataset.width=60000", "dataset.width"),  # with the height below: refused before allocating
    ("dataset.frames=two", "dataset.frames"),
    ("dataset.noise_sigma=-2", "dataset.noise_sigma"),
    ("dataset.cameras=[C1,C9]", "C9"),
    ("+realism.detector=OPENPOSE", "realism.detector"),
    ("+realism.keypoint_swap_rate=2", "realism.keypoint_swap_rate"),
    ("body.dof=many", "body.dof"),
    ("body.dof=40", "body.dof"),
    ("body.vertices=12.5", "body.vertices"),
    ("body.subject=S9", "S9"),
    ("optimizer.popsize=1", "optimizer.popsize"),
    ("evaluator.name=nope", "nope"),
    ("coverage.frames=0", "coverage.frames"),
    ("run_dir_busy=later", "run_dir_busy"),
    ("evaluation.missing_markers=ignore", "evaluation.missing_markers"),
    ("export_options.units=km", "export_options.units"),
    ("export_options.names=vicon", "export_options.names"),
    ("export_options.frame=lab", "export_options.frame"),
]


@pytest.mark.parametrize(("override", "key"), CASES, ids=[c[0] for c in CASES])
def test_a_bad_value_names_its_key_before_any_data_is_read(tmp_path, override, key):
    data = tmp_path / "data"
    extra = ["dataset.height=40000"] if override == "dataset.width=60000" else []
    outcome = mmocap(
        override,
        *extra,
        f"dataset.root={data}",
        f"hydra.run.dir={tmp_path / 'run'}",
        "progress=false" if not override.startswith("progress") else "overlays=0",
    )
    assert_clean_error(outcome, key)
    assert not data.exists(), "data was rendered before the config was checked"


def test_a_bad_value_in_the_last_job_of_a_sweep_stops_it_before_the_first_job(tmp_path):
    seeds = ",".join(str(s) for s in range(39)) + ",-1"
    sweep = tmp_path / "sweep"
    outcome = mmocap(
        "-m", f"seed={seeds}", f"dataset.root={tmp_path / 'data'}", f"hydra.sweep.dir={sweep}", "progress=false"
    )
    line = assert_clean_error(outcome, "sweep job 39", "seed=-1", "seed must be")
    assert "no job was started" in line
    assert not sweep.exists()
    assert not (tmp_path / "data").exists()


def test_an_unknown_key_gets_hydras_own_message_without_a_traceback(tmp_path):
    outcome = mmocap("tracking.evaluatoins=3", f"hydra.run.dir={tmp_path / 'run'}")
    assert outcome.code != 0
    assert "Traceback" not in outcome.stderr
    assert "tracking.evaluatoins" in outcome.stderr


BENCH_CASES = [
    ("table2", "--vertices", "500"),
    ("table2", "--vertices", "abc"),  # was a ValueError traceback
    ("table2", "--population", "0"),  # was a ZeroDivisionError traceback
    ("table2", "--repeats", "0"),  # was an infinite time per model-view
    ("table2", "--cameras", "99"),
    ("table1", "--budgets", "500,x"),
    ("table1", "--seconds", "-1"),
]


@pytest.mark.parametrize(("table", "option", "value"), BENCH_CASES, ids=[f"{c[1]}={c[2]}" for c in BENCH_CASES])
def test_a_bad_benchmark_argument_is_one_line_before_anything_is_built(tmp_path, table, option, value):
    outcome = mmocap("bench", table, option, value, "--backends", "numpy", "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert_clean_error(outcome, option)
    assert not (tmp_path / "out").exists()
