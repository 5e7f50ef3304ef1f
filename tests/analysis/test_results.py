"""Results store, run keys, the runs/frames tables, and the experiment x scale sweeps."""

import copy
import json
import logging
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from omegaconf import OmegaConf, open_dict

from mmocap import config as mmocap_config
from mmocap.analysis import results
from mmocap.analysis.results import (
    FIRST_SCHEMA,
    SCHEMA,
    AddedKey,
    ResultsStore,
    key_config,
    load_runs,
    run_key,
)
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.sweep import check_sweep, format_seconds, progress_line, sweep_overrides
from tests.helpers import compose_config, record_of

GOLDEN = Path(__file__).parents[1] / "golden" / "data"
SINGLE_RUNS = ("demo", "fig5")  # experiments that are one run, not a sweep
EXPERIMENTS = [name for name in mmocap_config.options("experiment") if name not in SINGLE_RUNS]
#: experiments whose scale is chosen under their own package (its dataset settings describe the
#: synthetic sequences their recordings are written from)
SCALE_PACKAGES = {"lossy": "scale@lossy"}
#: edits of a composed config (dotted key -> value) that cross each rule of the run key
KEY_EDITS = {
    "as composed": {},
    "keypoints none": {"keypoints.source": "none"},
    "keypoints files": {"keypoints.source": "files"},
    "fidelity levels": {"fidelity.levels": [{"scale": 0.5, "evaluations": 200}]},
    "fidelity levels null": {"fidelity.levels": None},
    "turned": {"dataset.turn_deg": 30},
    "turn 0.0": {"dataset.turn_deg": 0.0},
    "detector noise": {"realism.keypoint_noise": 0.7},
    "detector noise, keypoints none": {"realism.keypoint_noise": 0.7, "keypoints.source": "none"},
    "start keypoint evaluations": {"start.keypoint_evaluations": 100},
    "start keypoint evaluations, keypoints none": {"start.keypoint_evaluations": 100, "keypoints.source": "none"},
}


def edited(cfg, edits: dict):
    """A copy of the composed config ``cfg`` with ``edits`` (dotted key -> value; new keys added)."""
    cfg = copy.deepcopy(cfg)
    with open_dict(cfg):
        for key, value in edits.items():
            OmegaConf.update(cfg, key, value, force_add=True)
    return cfg


def test_run_key_ignores_outputs_and_presentation_only():
    base = run_key(compose_config())
    assert base == run_key(compose_config())
    assert len(base) == 16
    assert int(base, 16) >= 0
    for same in (
        ["progress=false"],
        ["overlays=0"],
        ["results.store=/x"],
        ["results.reuse=[/y]"],
        ["hydra.run.dir=/elsewhere"],
        ["export=[trc]", "export_options.units=m", "export_options.frame=calibration"],
        ["pin.require_clean=true", "+allow_dirty=true"],
    ):
        assert run_key(compose_config(*same)) == base, same
    changed = {
        run_key(compose_config(o))
        for o in (
            "seed=1",
            "tracking.evaluations=500",
            "body.dof=28",
            "optimizer=pso",
            "dataset.action=boxing",
            "body.vertices=20544",
        )
    }
    assert base not in changed
    assert len(changed) == 6


def test_the_settings_presets_name_does_not_enter_the_key_but_its_values_do():
    # the default config names no preset and runs the optimisers' own values: the tuned runs
    tuned = run_key(compose_config("+experiment=table4", "settings=tuned"))
    assert tuned == run_key(compose_config("+experiment=table4", "settings=tuned", "settings.name=renamed"))
    assert tuned == run_key(compose_config("+experiment=fig7", "settings=tuned"))  # Fig. 7 finds Table 4's runs
    assert run_key(compose_config("+experiment=table4", "settings=paper")) == run_key(
        compose_config("+experiment=fig7")
    )
    assert run_key(compose_config("+experiment=table4", "settings=paper")) != tuned


def test_scale_presets_do_not_enter_the_key_but_their_values_do():
    smoke = compose_config("+experiment=fig10", "scale=smoke")
    same_values = compose_config("+experiment=fig10", "scale=smoke", "scale.seeds=7")
    assert run_key(smoke) == run_key(same_values)
    assert run_key(smoke) != run_key(compose_config("+experiment=fig10", "scale=default"))


def test_store_put_get_and_records(tmp_path):
    cfg = compose_config("seed=3")
    store = ResultsStore(tmp_path)
    assert store.get(run_key(cfg)) is None
    path = store.put(record_of(cfg, [10.0, 20.0]))
    assert path == tmp_path / "records" / f"{run_key(cfg)}.json"
    assert not list(tmp_path.rglob("*.tmp"))
    record = store.get(run_key(cfg))
    assert record["seed"] == 3
    assert record["summary"]["frames"] == 2
    assert record["provenance"]["python"]
    assert "numpy" in record["provenance"]["versions"]
    assert record["provenance"]["components"]["optimizer"]["distribution"] == "mmocap"
    assert record["timings"]["evaluation_seconds_per_frame"] == pytest.approx(0.75)
    assert record["config"]["seed"] == 3
    assert "hydra" not in record["key_config"]
    store.put(record_of(compose_config("seed=4"), [1.0]))
    assert sorted(r["seed"] for r in store.records()) == [3, 4]


def test_adopt_copies_a_finished_run_from_another_store(tmp_path):
    cfg = compose_config("seed=5")
    ResultsStore(tmp_path / "a").put(record_of(cfg, [12.0]))
    mine = ResultsStore(tmp_path / "b")
    assert mine.adopt(run_key(compose_config("seed=6")), [tmp_path / "a"]) is None
    assert mine.adopt(run_key(cfg), [tmp_path / "missing", tmp_path / "a"])["seed"] == 5
    assert mine.get(run_key(cfg))["summary"]["mean_marker_error_mm"] == 12.0


def test_a_damaged_record_is_a_clear_error(tmp_path):
    store = ResultsStore(tmp_path)
    store.records_dir.mkdir()
    (store.records_dir / "0123456789abcdef.json").write_text('{"run_id": ')
    with pytest.raises(DataError, match=r"0123456789abcdef.json is not valid JSON"):
        store.get("0123456789abcdef")


def test_a_record_that_is_not_an_object_is_a_clear_error(tmp_path):
    store = ResultsStore(tmp_path)
    store.records_dir.mkdir()
    (store.records_dir / "0123456789abcdef.json").write_text("[1, 2]")
    with pytest.raises(DataError, match=r"0123456789abcdef.json is not a JSON object but list"):
        store.get("0123456789abcdef")
    (store.records_dir / "folder.json").mkdir()  # not a record: a folder
    assert store.run_ids() == ["0123456789abcdef"]


def broken(record: dict, part: str, key: str, value) -> dict:
    """``record`` with ``record[part][key]`` set to ``value`` (removed if it is ``...``)."""
    record = json.loads(json.dumps(record))
    target = record if part == "" else record[part]
    if value is ...:
        del target[key]
    else:
        target[key] = value
    return record


@pytest.mark.parametrize(
    ("part", "key", "value", "message"),
    [
        ("", "summary", ..., "lacks summary;"),
        ("", "summary", [1], "summary is [1], not a JSON object"),
        ("summary", "mean_marker_error_mm", ..., "lacks summary.mean_marker_error_mm"),
        ("summary", "mean_marker_error_mm", "low", "summary.mean_marker_error_mm is 'low', not a number or null"),
        ("summary", "dof", 39.5, "summary.dof is 39.5, not an integer"),
        ("summary", "optimizer", None, "summary.optimizer is None, not text"),
        ("timings", "seconds_per_frame", ..., "lacks timings.seconds_per_frame"),
        ("", "provenance", None, "provenance is None, not a JSON object"),
        ("", "frames", {"0": 1}, "frames is {'0': 1}, not a list"),
    ],
)
def test_a_record_missing_an_entry_or_with_one_of_the_wrong_kind_is_named(tmp_path, part, key, value, message):
    store = ResultsStore(tmp_path)
    path = store.put(broken(record_of(compose_config(), [4.0]), part, key, value))
    with pytest.raises(DataError) as err:
        load_runs(tmp_path)
    assert str(err.value).startswith(f"run record {path}")
    assert message in str(err.value)
    assert str(err.value).endswith("delete it to run that job again")


def test_a_frame_entry_is_checked_too(tmp_path):
    record = record_of(compose_config(), [4.0, 6.0])
    record["frames"][1]["frame"] = "one"
    path = ResultsStore(tmp_path).put(record)
    with pytest.raises(DataError, match=rf"{path}: frames\[1\].frame is 'one', not an integer"):
        load_runs(tmp_path)


def test_a_run_without_ground_truth_is_kept_empty_with_a_warning(tmp_path):
    store = ResultsStore(tmp_path)
    unscored = record_of(compose_config("seed=1"), [4.0])
    unscored["summary"]["mean_marker_error_mm"] = None
    unscored["frames"][0]["marker_error_mm"] = None
    store.put(unscored)
    store.put(record_of(compose_config("seed=2"), [6.0]))
    with pytest.warns(MmocapWarning, match=rf"1 of 2 run\(s\) .* no ground truth .*{unscored['run_id']}.json"):
        runs, frames = load_runs(tmp_path)
    by_seed = runs.set_index("seed")["mean_marker_error_mm"]
    assert np.isnan(by_seed[1])
    assert by_seed[2] == 6.0
    errors = frames.set_index("run_id")["marker_error_mm"]
    assert np.isnan(errors[unscored["run_id"]])
    assert len(frames) == 2


def test_load_runs_gives_the_contract_tables(tmp_path):
    store = ResultsStore(tmp_path)
    store.put(
        record_of(
            compose_config("seed=0", "algorithm=cmaes-hierarchical", "+experiment=cano_table3"),
            [10.0, 30.0],
            fitness=[0.2, 0.4],
        )
    )
    store.put(
        record_of(
            compose_config(
                "seed=1", "body.dof=28", "evaluator=opencl", "+experiment=table4", "settings=paper", "realism=realistic"
            ),
            [5.0, 7.0, 9.0],
            fitness=[0.1, 0.1, 0.4],
        )
    )
    runs, frames = load_runs(tmp_path)
    assert list(runs.columns[:22]) == [
        "run_id",
        "subject",
        "action",
        "sequence",
        "seed",
        "optimizer",
        "strategy",
        "algorithm",
        "settings",
        "realism",
        "turn_deg",
        "keypoints",
        "keypoint_weight",
        "dof",
        "evaluations",
        "vertices",
        "backend",
        "frames",
        "mean_marker_error_mm",
        "mean_best_fitness",
        "seconds_per_frame",
        "evaluation_seconds_per_frame",
    ]
    assert runs["run_id"].is_unique
    assert len(runs) == 2
    first, second = runs.set_index("seed").loc[0], runs.set_index("seed").loc[1]
    assert first["algorithm"] == "cmaes-hierarchical"
    assert first["sequence"] == "S1_walking"
    assert first["mean_marker_error_mm"] == 20.0
    assert first["frames"] == 2
    assert first["mean_best_fitness"] == pytest.approx(0.3)
    assert second["mean_best_fitness"] == pytest.approx(0.2)
    assert pd.isna(first["settings"])
    assert second["settings"] == "paper"
    assert first["realism"] == "exact"
    assert second["realism"] == "realistic"
    assert second["backend"] == "opencl"
    assert (first["keypoints"], first["keypoint_weight"], first["turn_deg"]) == ("none", 0.0, 0.0)  # silhouettes only
    assert runs["dof"].dtype.kind == "i"
    assert runs["seconds_per_frame"].dtype.kind == "f"
    assert list(frames.columns) == ["run_id", "frame", "marker_error_mm", "fitness"]
    assert len(frames) == 5
    assert (
        frames.groupby("run_id")["marker_error_mm"].mean().to_dict()
        == runs.set_index("run_id")["mean_marker_error_mm"].to_dict()
    )
    assert frames.groupby("run_id")["fitness"].mean().to_dict() == pytest.approx(
        runs.set_index("run_id")["mean_best_fitness"].to_dict()
    )


@pytest.mark.parametrize("bad", [None, float("nan"), float("inf")])
def test_a_frame_without_a_finite_fitness_empties_its_runs_mean_with_a_warning(tmp_path, bad):
    store = ResultsStore(tmp_path)
    gap = record_of(compose_config("seed=1"), [4.0, 6.0], fitness=[0.1, bad])
    store.put(gap)
    store.put(record_of(compose_config("seed=2"), [6.0], fitness=[0.3]))
    with pytest.warns(MmocapWarning, match=rf"1 of 2 run\(s\) .* without a finite fitness .*{gap['run_id']}.json"):
        runs, frames = load_runs(tmp_path)
    by_seed = runs.set_index("seed")
    assert np.isnan(by_seed.loc[1, "mean_best_fitness"])  # not 0.1, the mean of the frame that has one
    assert by_seed.loc[1, "mean_marker_error_mm"] == 5.0
    assert by_seed.loc[2, "mean_best_fitness"] == 0.3
    kept = frames[frames.run_id == gap["run_id"]]["fitness"].tolist()
    assert kept[0] == 0.1
    assert not np.isfinite(kept[1])


def test_a_frame_without_its_fitness_entry_is_named(tmp_path):
    record = record_of(compose_config(), [4.0, 6.0])
    del record["frames"][1]["fitness"]
    path = ResultsStore(tmp_path).put(record)
    with pytest.raises(DataError, match=rf"{path} lacks frames\[1\].fitness; delete it"):
        load_runs(tmp_path)


# Jobs per experiment and scale: the product of the sweep's value counts.
# Tables 4-7 run each with both settings presets, on realistic data (and at the default and
# paper scales on exact data too).
JOBS = {
    ("table4", "smoke"): 2 * 8 * 3 * 2,
    ("table4", "paper"): 2 * 2 * 8 * 3 * 9 * 30,
    ("table6", "default"): 2 * 2 * 4 * 2 * 3 * 3 * 2,
    ("fig10", "paper"): 2 * 2 * 4,
    ("cano_table3", "paper"): 2 * 3 * 4 * 6 * 10,
    ("fig4", "smoke"): 2 * 3 * 2 * 2,
    ("keypoint_weight", "paper"): 2 * 5 * 5,  # the realistic benchmark: 5 seeds
}


@pytest.mark.parametrize("experiment", EXPERIMENTS)
@pytest.mark.parametrize("scale", ["smoke", "default", "paper"])
def test_every_experiment_composes_at_every_scale(experiment, scale):
    key = SCALE_PACKAGES.get(experiment, "scale")
    cfg = compose_config(f"+experiment={experiment}", f"{key}={scale}", hydra=True)
    values = sweep_overrides(cfg)
    assert cfg.hydra.sweep.dir == f"outputs/sweeps/{experiment}/{scale}"
    if experiment in SCALE_PACKAGES:  # its dataset is a recording written from the scale's sequences
        assert cfg.dataset.root.startswith(f"outputs/recordings/{experiment}/{scale}/")
    else:
        assert cfg.dataset.root == f"outputs/data/{scale}"
    assert all(v and "$" not in "".join(v) for v in values.values()), values
    jobs = math.prod(len(v) for v in values.values())
    if (experiment, scale) in JOBS:
        assert jobs == JOBS[experiment, scale]
    if scale == "paper" and "seed" in values and experiment not in ("fig10", "keypoint_weight"):
        assert len(values["seed"]) in (10, 30)


def test_the_yeguas_algorithms_are_the_papers_eight():
    values = sweep_overrides(compose_config("+experiment=table4", hydra=True))
    assert len(values["algorithm"]) == 8
    for name in values["algorithm"]:
        cfg = compose_config(f"algorithm={name}", "+experiment=table4")
        optimizer, strategy = name.split("-")
        assert cfg.optimizer.name == optimizer
        assert strategy.capitalize() in cfg.strategy._target_


def test_command_line_values_replace_the_sweepers():
    cfg = compose_config("+experiment=table4", "scale=smoke", hydra=True)
    with open_dict(cfg):
        cfg.hydra.overrides.task = ["+experiment=table4", "seed=0,1,2", "body.dof=28"]
    values = sweep_overrides(cfg)
    assert values["seed"] == ["0", "1", "2"]
    assert values["body.dof"] == ["28"]


def test_a_sweep_that_cannot_run_is_caught():
    cfg = compose_config("+experiment=table4", hydra=True)
    check_sweep(cfg, {"optimizer.name": ["cmaes", "pso"]})
    with pytest.raises(ConfigError, match="unknown optimizer 'nope'; installed optimizers: .*cmaes"):
        check_sweep(cfg, {"optimizer.name": ["cmaes", "nope"]})
    with pytest.raises(ConfigError, match="unknown evaluator 'gpu9'"):
        check_sweep(cfg, {"evaluator.name": ["gpu9"]})
    with pytest.raises(ConfigError, match="evaluator=multiprocessing cannot start .* hydra.launcher.n_jobs=1"):
        check_sweep(cfg, {"evaluator": ["numpy", "multiprocessing"]})
    with pytest.raises(ConfigError, match="evaluator=multiprocessing"):
        check_sweep(compose_config("+experiment=table4", "evaluator=multiprocessing", hydra=True), {})
    check_sweep(
        compose_config("+experiment=table4", "hydra.launcher.n_jobs=1", hydra=True), {"evaluator": ["multiprocessing"]}
    )
    check_sweep(
        compose_config("+experiment=table4", "hydra/launcher=basic", hydra=True), {"evaluator": ["multiprocessing"]}
    )


def test_progress_line_counts_this_session_and_estimates_time_left(tmp_path):
    info = {"session": "s2", "jobs": 10, "started": 0.0}
    lines = [{"session": "s1", "job": 0, "ran": True}] + [{"session": "s2", "job": k, "ran": k >= 2} for k in range(4)]
    path = tmp_path / "progress.jsonl"
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    info["started"] = time.time() - 100  # 100 s for 2 runs: 50 s per run, 6 left
    text = progress_line(path, info)
    assert text.startswith("sweep: 4/10 runs done (2 found in the store), about 5 min 0")
    assert format_seconds(7) == "7 s"
    assert format_seconds(125) == "2 min 05 s"
    assert format_seconds(3725) == "1 h 02 min"


def test_a_paper_run_keeps_the_key_it_had_before_keypoints_existed():
    """Table 4's run at scale smoke, as keyed before keypoints, the realism's simulated
    detector and dataset.turn_deg existed: a silhouettes-only run does not read them, so its
    record in a store made then is still found."""
    cfg = compose_config(
        "+experiment=table4",
        "scale=smoke",
        "settings=paper",
        "realism=realistic",
        "algorithm=cmaes-holistic",
        "tracking.evaluations=390",
        "seed=0",
        "dataset.subject=S1",
        "dataset.action=walking",
    )
    assert cfg.keypoints.source == "none"
    assert run_key(cfg) == "778a5dbab9f5b3b7"  # the key of mmocap 98f12f6's record of this run
    with open_dict(cfg):
        cfg.keypoints.source = "auto"
    assert run_key(cfg) != "778a5dbab9f5b3b7"  # with keypoints it is another run


def test_every_experiments_run_keys_are_those_its_schema_gave():
    """The keys of every experiment's config (and its first job at scale smoke), each with the
    edits that cross the key's rules, as the code that made the schema's records gave them
    (``made_by`` in the file). A change of the key rules that moves one must declare the new
    key in ``ADDED_KEYS``, or raise ``SCHEMA`` and write ``run_keys_schema_<SCHEMA>.json``: the
    same configs and edits, with the keys the new rules give them (never rewrite an old one)."""
    golden = json.loads((GOLDEN / f"run_keys_schema_{SCHEMA}.json").read_text())
    moved = []
    for name, case in golden["configs"].items():
        cfg = compose_config(*case["overrides"])
        for edit, key in case["keys"].items():
            if run_key(edited(cfg, golden["edits"][edit])) != key:
                moved.append(f"{name}: {edit}")
    assert len(golden["configs"]) >= len(mmocap_config.options("experiment"))
    assert moved == [], f"{len(moved)} run keys moved, e.g. {moved[:3]}"


def test_a_new_block_or_key_at_its_neutral_value_keeps_every_key_and_otherwise_moves_it(monkeypatch):
    """What a new config block needs so that the records made before it keep their keys: one
    line in ADDED_KEYS. Without it, even a block that changes nothing moves every key."""
    golden = json.loads((GOLDEN / f"run_keys_schema_{SCHEMA}.json").read_text())
    cases = [golden["configs"][name] for name in ("table4 smoke, first job", "demo", "lossy smoke, first job")]
    gizmo = {"gizmo": {"enabled": False, "strength": 3}}
    for case in cases:
        cfg, key = compose_config(*case["overrides"]), case["keys"]["as composed"]
        assert run_key(edited(cfg, gizmo)) != key  # not declared
        with monkeypatch.context() as patch:
            patch.setattr(
                results,
                "ADDED_KEYS",
                (
                    *results.ADDED_KEYS,
                    AddedKey("gizmo.enabled", (False,), drops=("gizmo",)),
                    AddedKey("tracking.jitter_mm", (0, None)),
                ),
            )
            assert run_key(edited(cfg, gizmo)) == key
            assert run_key(edited(cfg, {"tracking.jitter_mm": 0.0})) == key
            assert run_key(edited(cfg, {"tracking.jitter_mm": None})) == key
            assert run_key(edited(cfg, {"gizmo.enabled": True, "gizmo.strength": 3})) != key
            assert run_key(edited(cfg, {"tracking.jitter_mm": 2.0})) != key
            assert "gizmo" not in key_config(edited(cfg, gizmo))


def test_a_store_knows_its_schema_and_a_record_carries_it(tmp_path):
    store = ResultsStore(tmp_path)
    assert store.schema() is None  # empty: any mmocap may write into it
    path = store.put(record_of(compose_config("seed=3"), [10.0]))
    assert json.loads(path.read_text())["schema"] == SCHEMA
    assert json.loads((tmp_path / "store.json").read_text()) == {"schema": SCHEMA}
    assert store.schema() == SCHEMA
    (tmp_path / "store.json").unlink()  # a store made before stores had a schema
    assert store.schema() == FIRST_SCHEMA
    store.check_schema()


def test_a_store_of_another_schema_is_refused_saying_what_to_do(tmp_path, monkeypatch):
    store = ResultsStore(tmp_path)
    store.put(record_of(compose_config("seed=3"), [10.0]))
    monkeypatch.setattr(results, "SCHEMA", SCHEMA + 1)
    with pytest.raises(DataError, match=rf"holds records of schema {SCHEMA}.*`mmocap store migrate {tmp_path}`"):
        store.check_schema()
    store.set_schema(SCHEMA + 2)
    with pytest.raises(DataError, match=rf"is of schema {SCHEMA + 2} .*newer than this mmocap's {SCHEMA + 1}"):
        store.check_schema()


#: a process that holds the claim of run argv[2] in the store argv[1] for argv[3] seconds
CLAIM_HOLDER = """
import sys, time
from mmocap.analysis.results import ResultsStore
with ResultsStore(sys.argv[1]).claim(sys.argv[2]):
    print("claimed", flush=True)
    time.sleep(float(sys.argv[3]))
"""
RUN_ID = "0123456789abcdef"


def hold_claim(folder, seconds: float) -> subprocess.Popen:
    """A process holding the claim of :data:`RUN_ID` in the store ``folder`` for ``seconds``."""
    holder = subprocess.Popen(
        [sys.executable, "-c", CLAIM_HOLDER, str(folder), RUN_ID, str(seconds)], stdout=subprocess.PIPE, text=True
    )
    assert holder.stdout.readline().strip() == "claimed"
    return holder


def test_a_run_claimed_by_another_process_is_waited_for(tmp_path, caplog):
    store = ResultsStore(tmp_path)
    holder = hold_claim(tmp_path, 1.5)
    assert store.claim_path(RUN_ID).read_text().startswith(f"process {holder.pid} on ")
    start = time.monotonic()
    with caplog.at_level(logging.INFO, logger="mmocap.analysis.results"), store.claim(RUN_ID):
        waited = time.monotonic() - start
        assert store.claim_path(RUN_ID).read_text().startswith(f"process {os.getpid()} on ")
    assert waited > 1.0  # the holder slept 1.5 s after claiming
    assert holder.wait(timeout=10) == 0
    assert f"run {RUN_ID} is being run by process {holder.pid} on" in caplog.text
    assert "waiting for its record" in caplog.text
    assert not store.claim_path(RUN_ID).exists()


def test_the_claim_a_killed_process_left_is_taken_over(tmp_path):
    store = ResultsStore(tmp_path)
    holder = hold_claim(tmp_path, 60)
    holder.kill()
    holder.wait()
    assert store.claim_path(RUN_ID).exists()  # a killed job leaves its claim
    start = time.monotonic()
    with store.claim(RUN_ID):
        assert time.monotonic() - start < 5
        assert store.claim_path(RUN_ID).read_text().startswith(f"process {os.getpid()} on ")
    assert list(store.records_dir.iterdir()) == []


def test_a_runs_mean_fitness_does_not_depend_on_the_frames_order():
    # summed in order, 0.1 + 0.2 + 0.3 and 0.3 + 0.2 + 0.1 differ in the last bit: two runs
    # with the same frames' fitness would then not tie in the statistics
    assert (0.1 + 0.2) + 0.3 != (0.3 + 0.2) + 0.1
    assert results.mean_best_fitness([0.1, 0.2, 0.3]) == results.mean_best_fitness([0.3, 0.2, 0.1]) == 0.2
