"""Results store: one record per finished run, kept in a store that makes sweeps resumable.

A store is a folder (a sweep's folder, or a single run's) holding ``records/<run_id>.json``.
A record is written once, atomically (temporary file then ``os.replace``), when its run
finishes: a run killed midway leaves no record and is run again by the next sweep, a
finished run is never run twice. ``run_id`` is a digest of the run's resolved config
without what does not change its result (output paths, progress bars, overlays, the
``scale`` presets, ``run_dir_busy``, Hydra's own settings).

``load_runs(folder)`` gives the two tables the statistics and reports read:

- ``runs``: one row per run: run_id, subject, action, sequence, seed, optimizer, strategy,
  algorithm (``"<optimizer>-<strategy>"``), dof, evaluations (per frame), vertices,
  backend, frames, mean_marker_error_mm, seconds_per_frame (wall time of tracking),
  evaluation_seconds_per_frame (time inside the evaluator), git_commit, host;
- ``frames``: one row per tracked frame: run_id, frame, marker_error_mm.

``mmocap collect FOLDER`` writes them as ``runs.csv`` and ``frames.csv``.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import DictConfig, OmegaConf

from mmocap import provenance
from mmocap.errors import DataError
from mmocap.io import write_json_atomic, write_text_atomic

# Top-level config keys that do not change a run's result.
NOT_IN_KEY = ("hydra", "progress", "overlays", "results", "scale", "foreground_cache", "run_dir_busy",
              "evaluation")

RUN_COLUMNS = ["run_id", "subject", "action", "sequence", "seed", "optimizer", "strategy",
               "algorithm", "dof", "evaluations", "vertices", "backend", "frames",
               "mean_marker_error_mm", "seconds_per_frame", "evaluation_seconds_per_frame",
               "git_commit", "host"]
FRAME_COLUMNS = ["run_id", "frame", "marker_error_mm"]


def key_config(cfg: DictConfig) -> dict:
    """The resolved config that identifies a run: everything but ``NOT_IN_KEY``."""
    kept = {}
    for key in cfg:
        if key not in NOT_IN_KEY:
            node = cfg[key]  # interpolations resolve against the whole config
            kept[key] = OmegaConf.to_container(node, resolve=True) if OmegaConf.is_config(node) else node
    return kept


def run_key(cfg: DictConfig) -> str:
    """16 hex digits identifying the run ``cfg`` describes (same config, same key)."""
    text = json.dumps(key_config(cfg), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def store_folder(cfg: DictConfig, fallback: Path) -> Path:
    """The results store of a run: ``results.store`` if set, else ``fallback`` (the
    sweep folder in a multirun, the run's own folder otherwise)."""
    return Path(cfg.results.store if cfg.results.store is not None else fallback)


class ResultsStore:
    """The records of finished runs under ``folder/records/``."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self.records_dir = self.folder / "records"

    def path(self, run_id: str) -> Path:
        return self.records_dir / f"{run_id}.json"

    def get(self, run_id: str) -> dict | None:
        """The record of ``run_id``, or None if that run has not finished here."""
        path = self.path(run_id)
        if not path.is_file():
            return None
        try:
            return json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise DataError(f"run record {path} is not valid JSON ({exc}); delete it to run again") from None

    def put(self, record: dict) -> Path:
        """Write ``record`` atomically; returns its path."""
        self.records_dir.mkdir(parents=True, exist_ok=True)
        path = self.path(record["run_id"])
        write_json_atomic(path, record)
        return path

    def adopt(self, run_id: str, others) -> dict | None:
        """Copy the record of ``run_id`` from the first of the stores ``others`` that has
        it into this one; returns it, or None if none has it."""
        for folder in others:
            record = ResultsStore(folder).get(run_id)
            if record is not None and Path(folder).resolve() != self.folder.resolve():
                self.put(record)
                return record
        return None

    def run_ids(self) -> list[str]:
        """The run_id of every finished run, sorted."""
        return sorted(p.stem for p in self.records_dir.glob("*.json")) if self.records_dir.is_dir() else []

    def records(self) -> list[dict]:
        """Every record, in run_id order."""
        return [self.get(run_id) for run_id in self.run_ids()]


def make_record(cfg: DictConfig, summary: dict, frames: list[dict], wall_seconds: float,
                evaluation_seconds: float, started: str, output_dir: Path) -> dict:
    """The record of a finished run: identity, config, per-frame results, timings, and the
    provenance the summary carries (:mod:`mmocap.provenance`: versions, commit, host, and
    where the optimiser and evaluator come from).

    ``frames``: one dict per tracked frame with frame, marker_error_mm, fitness,
    evaluations, seconds. Times in seconds.
    """
    n = max(len(frames), 1)
    return {
        "run_id": run_key(cfg),
        "summary": {k: v for k, v in summary.items() if k not in ("config", "provenance")},
        "frames": frames,
        "timings": {"wall_seconds": wall_seconds, "seconds_per_frame": wall_seconds / n,
                    "evaluation_seconds": evaluation_seconds,
                    "evaluation_seconds_per_frame": evaluation_seconds / n},
        "seed": int(cfg.seed),
        "config": OmegaConf.to_container(cfg, resolve=True),
        "key_config": key_config(cfg),
        "provenance": summary["provenance"],
        "started": started,
        "finished": provenance.now(),
        "output_dir": str(output_dir),
    }


#: the summary entries a runs table is made of
SUMMARY_KEYS = ("subject", "action", "optimizer", "strategy", "dof", "evaluations_per_frame", "vertices",
                "backend", "frames", "mean_marker_error_mm")


def run_row(record: dict, source: str = "record") -> dict:
    """One row of the ``runs`` table from a record; ``mean_marker_error_mm`` is empty (NaN)
    for a run without ground truth. A record missing a part is a DataError naming ``source``."""
    missing = [key for key in ("run_id", "seed", "summary", "timings", "provenance") if key not in record]
    missing += [f"summary.{key}" for key in SUMMARY_KEYS if key not in record.get("summary", {})]
    if missing:
        raise DataError(f"run record {source} lacks {', '.join(missing)}; delete it to run that job again")
    s, t, p = record["summary"], record["timings"], record["provenance"]
    return {
        "run_id": record["run_id"], "subject": s["subject"], "action": s["action"],
        "sequence": f"{s['subject']}_{s['action']}", "seed": int(record["seed"]),
        "optimizer": s["optimizer"], "strategy": s["strategy"],
        "algorithm": f"{s['optimizer']}-{s['strategy']}", "dof": int(s["dof"]),
        "evaluations": int(s["evaluations_per_frame"]), "vertices": int(s["vertices"]),
        "backend": s["backend"], "frames": int(s["frames"]),
        "mean_marker_error_mm": np.nan if s["mean_marker_error_mm"] is None else float(s["mean_marker_error_mm"]),
        "seconds_per_frame": float(t["seconds_per_frame"]),
        "evaluation_seconds_per_frame": float(t.get("evaluation_seconds_per_frame", np.nan)),
        "git_commit": p.get("git_commit"), "host": p.get("host"),
    }


def load_runs(folder) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``(runs, frames)`` tables of every record in the store ``folder`` (see module doc)."""
    store = ResultsStore(folder)
    records = store.records()
    if not records:
        raise DataError(f"no run records in {store.records_dir}: has a sweep run into {store.folder}?")
    runs = pd.DataFrame([run_row(r, str(store.path(i))) for i, r in zip(store.run_ids(), records)],
                        columns=RUN_COLUMNS)
    frames = pd.DataFrame([(r["run_id"], int(f["frame"]), float(f["marker_error_mm"]))
                           for r in records for f in r["frames"]], columns=FRAME_COLUMNS)
    return runs, frames


def export(folder) -> tuple[Path, Path]:
    """Write ``runs.csv`` and ``frames.csv`` into the store ``folder``; returns their paths."""
    folder = Path(folder)
    runs, frames = load_runs(folder)
    return (write_text_atomic(folder / "runs.csv", runs.to_csv(index=False)),
            write_text_atomic(folder / "frames.csv", frames.to_csv(index=False)))


def main(argv: list[str], prog: str) -> None:
    """``mmocap collect FOLDER``: write runs.csv and frames.csv of a results store."""
    import argparse

    parser = argparse.ArgumentParser(prog=prog, description="Write runs.csv and frames.csv of a results store.")
    parser.add_argument("folder", type=Path, help="a sweep folder (holding records/)")
    runs_csv, frames_csv = export(parser.parse_args(argv).folder)
    print(f"{runs_csv} ({len(pd.read_csv(runs_csv))} runs), {frames_csv}")
