"""Bad input, the file system: output folders that are read-only, full or a file, a run
folder another run is writing into, files torn or left behind by a crash.

A fault ends in one line naming the path, what is wrong and how to fix it, exit status 2, and
leaves nothing half-written (the rules of :mod:`mmocap.io`): no run record, no temporary
file, no ``summary.json`` of an incomplete run, no partial export.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from mmocap.io import locked
from mmocap.run_folder import RUN_LOCK
from tests.helpers import assert_clean_error, track_args
from tests.helpers import mmocap_in_process as mmocap

#: what a read-only folder is called: root writes through permission bits, so
#: ``make_read_only`` mounts a read-only file system for root and removes permissions otherwise
READ_ONLY = "the file system is read-only" if os.geteuid() == 0 else "permission denied"
#: overrides that have the synthetic dataset render a tiny sequence (dataset.root added)
SYNTHETIC = [
    "dataset.frames=2",
    "dataset.width=160",
    "dataset.height=120",
    "dataset.cameras=[C1,BW1]",
    "dataset.all_cameras=[C1,BW1]",
    "dataset.background_frames=3",
    "body.vertices=1000",
    "tracking.evaluations=60",
    "evaluator=numpy",
    "progress=false",
    "foreground_cache=null",
]


def fill(disk: Path, leave: int) -> None:
    """Fill ``disk`` (a small tmpfs) up to ``leave`` bytes of free space."""
    (disk / "filler").write_bytes(bytes(max(shutil.disk_usage(disk).free - leave, 0)))


def sweep_args(root: Path, sweep: Path) -> list[str]:
    """A one-job multirun of the sequence folder ``root`` into ``sweep``, in this process."""
    return [
        "-m",
        *[a for a in track_args(root, sweep) if not a.startswith("hydra.run.dir=")],
        f"hydra.sweep.dir={sweep}",
        "hydra/launcher=basic",
        "overlays=0",
    ]


def assert_nothing_half_written(folder: Path) -> None:
    """No record, no summary.json, no temporary file under ``folder``."""
    if folder.is_dir():
        assert not list(folder.rglob("records/*.json")), "an incomplete run wrote its record"
        assert not (folder / "summary.json").exists(), "an incomplete run wrote summary.json"
        assert not list(folder.rglob("*.tmp")), f"temporary files left: {list(folder.rglob('*.tmp'))}"


# --- the run folder (hydra.run.dir) --------------------------------------------------------
# each: (fixture request, tmp_path) -> (the run folder, the words the error must hold)


def read_only_run_folder(request, tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    request.getfixturevalue("make_read_only")(out)
    return out, [str(out), READ_ONLY]


def run_folder_is_a_file(request, tmp_path):
    out = tmp_path / "run"
    out.write_text("a file where the run folder should be")
    return out, [str(out), "is a file, where a folder is needed"]


def run_folder_under_a_file(request, tmp_path):
    (tmp_path / "outputs").write_text("a file where a folder should be")
    return tmp_path / "outputs" / "run", [str(tmp_path / "outputs"), "is a file"]


def disk_full_before_the_run(request, tmp_path):
    disk = request.getfixturevalue("small_disk")
    fill(disk, 0)
    return disk / "run", [str(disk / "run"), "the disk is full", "free some space"]


def disk_fills_during_the_run(request, tmp_path):
    """Room for Hydra's files and the frames, not for the figure and overlay (~100 KB)."""
    disk = request.getfixturevalue("small_disk")
    fill(disk, 64 * 1024)
    return disk / "run", [str(disk / "run"), "the disk is full", "free some space"]


RUN_FOLDERS = [
    read_only_run_folder,
    run_folder_is_a_file,
    run_folder_under_a_file,
    disk_full_before_the_run,
    disk_fills_during_the_run,
]


@pytest.mark.parametrize("make", RUN_FOLDERS, ids=[m.__name__.replace("_", "-") for m in RUN_FOLDERS])
def test_a_run_folder_that_cannot_be_written_is_named_and_no_record_is_written(sequence_copy, tmp_path, request, make):
    out, words = make(request, tmp_path)
    before = out.read_text() if out.is_file() else None
    assert_clean_error(mmocap(*track_args(sequence_copy, out)), *words)
    assert_nothing_half_written(out)
    if before is not None:
        assert out.read_text() == before


def test_a_read_only_dataset_root_the_synthetic_sequence_must_render_into(tmp_path, make_read_only):
    root = tmp_path / "data"
    root.mkdir()
    make_read_only(root)
    out = tmp_path / "run"
    assert_clean_error(
        mmocap(f"dataset.root={root}", *SYNTHETIC, f"hydra.run.dir={out}"), str(root / "S1_walking"), READ_ONLY
    )
    assert list(root.iterdir()) == []
    assert_nothing_half_written(out)


# --- stats --out -----------------------------------------------------------------------------


@pytest.fixture
def results_table(tmp_path) -> Path:
    """A table the Friedman test accepts: 3 algorithms on 4 blocks."""
    rows = [(block, name, value + block) for block in range(4) for name, value in zip("abc", (1.0, 2.0, 3.5))]
    path = tmp_path / "results.csv"
    pd.DataFrame(rows, columns=["block", "algorithm", "value"]).to_csv(path, index=False)
    return path


@pytest.mark.parametrize("where", ["read-only", "under-a-file"])
def test_stats_out_that_cannot_be_written(results_table, tmp_path, make_read_only, where):
    folder = tmp_path / "tables"
    if where == "read-only":
        folder.mkdir()
        make_read_only(folder)
        words = [f"cannot write {folder}:", READ_ONLY]  # checked before the test runs
    else:
        folder.write_text("a file where the tables folder should be")
        words = [str(folder), "is a file, where a folder is needed"]
    outcome = mmocap("stats", results_table, "--block", "block", "--value", "value", "--out", folder / "stem")
    assert_clean_error(outcome, *words)
    assert not list(tmp_path.rglob("stem.*"))
    assert not list(tmp_path.rglob("*.tmp"))


# --- export-humaneva -------------------------------------------------------------------------


def export_into_a_file(request, tmp_path):
    out = tmp_path / "humaneva"
    out.write_text("a file where the export should go")
    return out, [str(out), "is a file, where a folder is needed"]


def export_onto_a_read_only_disk(request, tmp_path):
    out = tmp_path / "humaneva"
    (out / "S2").mkdir(parents=True)
    (out / "S2" / "kept.txt").write_text("an earlier export")
    request.getfixturevalue("make_read_only")(out)
    return out, [str(out), READ_ONLY]


def export_onto_a_full_disk(request, tmp_path):
    """The disk fills midway: the videos of the tiny sequence take ~400 KB."""
    disk = request.getfixturevalue("small_disk")
    (disk / "humaneva" / "S2").mkdir(parents=True)
    (disk / "humaneva" / "S2" / "kept.txt").write_text("an earlier export")
    fill(disk, 96 * 1024)
    return disk / "humaneva", [str(disk / "humaneva"), "the disk is full"]


EXPORTS = [export_into_a_file, export_onto_a_read_only_disk, export_onto_a_full_disk]


def snapshot(path: Path) -> dict:
    if path.is_file():
        return {"": path.read_bytes()}
    return {str(p.relative_to(path)): p.read_bytes() if p.is_file() else None for p in sorted(path.rglob("*"))}


@pytest.mark.parametrize("make", EXPORTS, ids=[m.__name__.replace("_", "-") for m in EXPORTS])
def test_export_humaneva_that_cannot_be_written_leaves_no_partial_export(sequence_copy, tmp_path, request, make):
    out, words = make(request, tmp_path)
    before = snapshot(out)
    assert_clean_error(mmocap("export-humaneva", sequence_copy, out), *words)
    assert snapshot(out) == before  # as it was: nothing of the failed export, nothing lost


# --- a run folder in use -----------------------------------------------------------------------


def test_a_second_run_into_a_run_folder_in_use_refuses_naming_it(sequence_copy, tmp_path):
    out = tmp_path / "run"
    with locked(out / RUN_LOCK):  # the first run, tracking
        outcome = mmocap(*track_args(sequence_copy, out))
    assert_clean_error(outcome, str(out), "in use by another run", f"process {os.getpid()}", "run_dir_busy=wait")
    assert not (out / "frames.csv.partial").exists()
    assert not (out / "frames.csv").exists()


def test_with_run_dir_busy_wait_the_second_run_waits_for_the_first(sequence_copy, tmp_path):
    out = tmp_path / "run"
    with locked(out / RUN_LOCK):
        second = subprocess.Popen(
            [sys.executable, "-m", "mmocap", *track_args(sequence_copy, out), "run_dir_busy=wait"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + 60
        while not (out / "cli.log").exists() and time.monotonic() < deadline:  # Hydra has set the run up
            time.sleep(0.05)
        time.sleep(1.0)
        assert second.poll() is None, "the second run did not wait"
        assert not (out / "frames.csv.partial").exists()
    _, stderr = second.communicate(timeout=120)
    assert second.returncode == 0, stderr
    assert len(pd.read_csv(out / "frames.csv")) == 2


def test_a_bad_run_dir_busy_names_the_key(sequence_copy, tmp_path):
    outcome = mmocap(*track_args(sequence_copy, tmp_path / "run"), "run_dir_busy=later")
    assert_clean_error(outcome, "run_dir_busy", "refuse, wait", "'later'")


# --- files torn or left behind by a crash ------------------------------------------------------


def test_a_torn_last_line_of_progress_jsonl_is_skipped(sequence_copy, tmp_path):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    progress = sweep / "progress.jsonl"
    progress.write_text('{"session": "old", "job": 0, "status": "COMPLETED", "ran": true}\n{"session": "old", "jo')
    outcome = mmocap(*sweep_args(sequence_copy, sweep))
    assert outcome.code == 0, outcome
    assert "Traceback" not in outcome.stderr, outcome
    assert "sweep: 1/1 runs done (0 found in the store)" in outcome.stdout + outcome.stderr, outcome
    lines = progress.read_text().splitlines()
    assert lines[1] == '{"session": "old", "jo'
    assert json.loads(lines[2])["ran"] is True


def test_temporary_files_left_by_a_crash_are_ignored_or_cleaned(sequence_copy, tmp_path):
    out = tmp_path / "run"
    (out / "records").mkdir(parents=True)
    stale = {
        out / "records" / ".0123456789abcdef.json.a1b2c3.tmp": '{"run_id": "0123',  # a record torn by SIGKILL
        out / ".summary.json.d4e5f6.tmp": '{"mean',
        out / "frames.csv.partial": "frame,marker_error_mm\n0,1",
    }
    for path, text in stale.items():
        path.write_text(text)
    outcome = mmocap(*track_args(sequence_copy, out))
    assert outcome.code == 0, outcome
    assert [p.suffix for p in (out / "records").iterdir() if not p.name.startswith(".")] == [".json"]
    assert not (out / ".summary.json.d4e5f6.tmp").exists()
    assert not (out / "frames.csv.partial").exists()
    assert len(pd.read_csv(out / "frames.csv")) == 2
    collected = mmocap("collect", out)
    assert collected.code == 0, collected
    assert len(pd.read_csv(out / "runs.csv")) == 1
