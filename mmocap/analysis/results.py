"""Results store: one record per finished run, kept in a store that makes sweeps resumable.

A store is a folder (a sweep's folder, or a single run's) holding ``records/<run_id>.json``.
A record is written once, atomically (temporary file then ``os.replace``), when its run
finishes: a run killed midway leaves no record and is run again by the next sweep, a
finished run is never run twice. ``run_id`` is a digest of the run's resolved config
without what does not change its result (output paths, progress bars, overlays, the
``scale`` presets, the name of the ``settings`` preset (its optimiser values stay in the
key), ``run_dir_busy``, Hydra's own settings).

``load_runs(folder)`` gives the two tables the statistics and reports read:

- ``runs``: one row per run: run_id, subject, action, sequence, seed, optimizer, strategy,
  algorithm (``"<optimizer>-<strategy>"``), settings (the optimiser settings preset the run
  named, ``paper`` or ``tuned`` (``conf/settings/``), empty if none), realism (the synthetic
  data's ``realism`` level, ``conf/realism/``; empty for other datasets), turn_deg (how far the
  synthetic motion was turned, ``dataset.turn_deg``; 0 for other datasets), keypoints (where the
  fitness's 2-D keypoints came from: ``files``, ``segmentation``, ``detector``, or ``none``
  for silhouettes only), keypoint_weight (the keypoint term's weight, 0 without keypoints),
  dof, evaluations (per
  frame), vertices, backend, frames, mean_marker_error_mm, mean_best_fitness (the mean over
  the frames of each frame's best silhouette fitness, Yeguas Eq. 5: in [0, 1], 0 = the model
  covers the foreground exactly), seconds_per_frame (wall time of the search, the foreground
  read apart), evaluation_seconds_per_frame (time inside the evaluator), git_commit, host;
- ``frames``: one row per tracked frame: run_id, frame, marker_error_mm, fitness.

Errors are empty (NaN) where there is no ground truth: ``mean_marker_error_mm`` of a run
with no scored frame and ``marker_error_mm`` of an unscored frame. A frame's fitness is NaN
where the record holds null; a run with a frame whose fitness is not finite has an empty
``mean_best_fitness`` rather than a mean over its other frames. A warning names the runs
left empty either way, and the statistics refuse them. A record missing an entry,
or holding one of the wrong kind, is a DataError naming the record file and the entry.

``mmocap collect FOLDER`` (:mod:`mmocap.report.collect`) writes them as ``runs.csv`` and
``frames.csv``.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from omegaconf import DictConfig, OmegaConf

from mmocap import provenance
from mmocap.data.realism import DETECTOR_SETTINGS
from mmocap.errors import DataError, MmocapWarning
from mmocap.io import read_json_object, write_json_atomic
from mmocap.validate import is_integer, is_real

# Top-level config keys that do not change a run's result.
NOT_IN_KEY = (
    "hydra",
    "progress",
    "overlays",
    "results",
    "scale",
    "settings",
    "foreground_cache",
    "run_dir_busy",
    "evaluation",
    "export",
    "export_options",
    "video",
    "plausibility",
    "pin",
    "allow_dirty",
)

RUN_COLUMNS = [
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
    "start",
    "start_seconds",
    "git_commit",
    "host",
]
FRAME_COLUMNS = ["run_id", "frame", "marker_error_mm", "fitness"]


def key_config(cfg: DictConfig) -> dict:
    """The resolved config that identifies a run: everything but ``NOT_IN_KEY``, and the
    blocks of stages that the run does not use, so that the records made before those
    stages existed still match: ``fidelity`` when it has no levels (an exact search), and
    ``dataset.turn_deg`` at 0 (the sequence not turned), and ``keypoints`` when its source is
    ``none`` (silhouettes only), and then the realism's simulated detector
    (:data:`~mmocap.data.realism.DETECTOR_SETTINGS`) and the start's ``keypoint_*`` settings,
    which such a run does not read."""
    kept: dict[str, Any] = {}
    silhouettes_only = cfg.get("keypoints") is not None and cfg.keypoints.get("source") == "none"
    for key in cfg:
        if key == "fidelity" and not cfg[key].get("levels"):
            continue
        if key == "keypoints" and silhouettes_only:
            continue
        if key not in NOT_IN_KEY:
            node = cfg[key]  # interpolations resolve against the whole config
            kept[str(key)] = OmegaConf.to_container(node, resolve=True) if OmegaConf.is_config(node) else node
    dataset: dict = kept["dataset"] if isinstance(kept.get("dataset"), dict) else {}
    if dataset.get("turn_deg") == 0:  # not turned: the sequence as before
        del dataset["turn_deg"]
    if silhouettes_only:  # the keypoint files and the start's keypoint settings are not read
        for realism in (kept.get("realism"), dataset.get("realism")):
            if isinstance(realism, dict):
                for setting in DETECTOR_SETTINGS:
                    realism.pop(setting, None)
        start: dict = kept["start"] if isinstance(kept.get("start"), dict) else {}
        for setting in [k for k in start if str(k).startswith("keypoint_")]:
            del start[setting]
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
        """The record file of ``run_id``: ``records/<run_id>.json`` in the store's folder."""
        return self.records_dir / f"{run_id}.json"

    def get(self, run_id: str) -> dict | None:
        """The record of ``run_id``, or None if that run has not finished here."""
        path = self.path(run_id)
        if not path.is_file():
            return None
        return read_json_object(path, name=f"run record {path}", fix="delete it to run again")

    def clear_unfinished(self, run_id: str) -> None:
        """Remove what an interrupted write of ``run_id``'s record left (its temporaries);
        called by the job that now runs ``run_id``, the only writer of that record."""
        for path in self.records_dir.glob(f".{run_id}.json.*.tmp"):
            path.unlink(missing_ok=True)

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
        if not self.records_dir.is_dir():
            return []
        return sorted(p.stem for p in self.records_dir.glob("*.json") if p.is_file())

    def records(self) -> list[dict]:
        """Every record, in run_id order."""
        return [self.get(run_id) for run_id in self.run_ids()]  # type: ignore[misc]  # listed: each exists


def make_record(
    cfg: DictConfig,
    summary: dict,
    frames: list[dict],
    search_seconds: float,
    evaluation_seconds: float,
    foreground_seconds: float,
    started: str,
    output_dir: Path,
) -> dict:
    """The record of a finished run: identity, config, per-frame results, timings, and the
    provenance the summary carries (:mod:`mmocap.provenance`: versions, commit, host, and
    where the optimiser and evaluator come from).

    ``frames``: one dict per tracked frame with frame, marker_error_mm, fitness,
    evaluations, seconds (the search), foreground_seconds. Times in seconds: the frames'
    searches (``search_seconds``; its per-frame mean is ``seconds_per_frame``), the part of
    them inside the evaluator, and the reading of their foreground, timed apart from the
    search (background subtraction on a mask-cache miss costs more than a search).
    """
    n = max(len(frames), 1)
    return {
        "run_id": run_key(cfg),
        "summary": {k: v for k, v in summary.items() if k not in ("config", "provenance")},
        "frames": frames,
        "timings": {
            "search_seconds": search_seconds,
            "seconds_per_frame": search_seconds / n,
            "evaluation_seconds": evaluation_seconds,
            "evaluation_seconds_per_frame": evaluation_seconds / n,
            "foreground_seconds": foreground_seconds,
            "foreground_seconds_per_frame": foreground_seconds / n,
        },
        "seed": int(cfg.seed),
        "config": OmegaConf.to_container(cfg, resolve=True),
        "key_config": key_config(cfg),
        "provenance": summary["provenance"],
        "started": started,
        "finished": provenance.now(),
        "output_dir": str(output_dir),
    }


#: what a runs table takes from a record: part -> {key: kind}; a kind ending in "?" may be null
RECORD_ENTRIES = {
    "record": {
        "run_id": "text",
        "seed": "integer",
        "frames": "list",
        "summary": "object",
        "timings": "object",
        "provenance": "object",
    },
    "summary": {
        "subject": "text",
        "action": "text",
        "optimizer": "text",
        "strategy": "text",
        "dof": "integer",
        "evaluations_per_frame": "integer",
        "vertices": "integer",
        "backend": "text",
        "frames": "integer",
        "mean_marker_error_mm": "number?",
    },
    "timings": {"seconds_per_frame": "number"},
    "provenance": {},
}
#: what every entry of a record's ``frames`` holds
FRAME_ENTRIES = {"frame": "integer", "marker_error_mm": "number?", "fitness": "number?"}
KIND_NAMES = {
    "text": "text",
    "integer": "an integer",
    "number": "a number",
    "list": "a list",
    "object": "a JSON object",
}
DAMAGED = "delete it to run that job again"


def _is_kind(value, kind: str) -> bool:
    """Whether a JSON value is of ``kind`` (a key of :data:`KIND_NAMES`, "?" appended: or null)."""
    if value is None:
        return kind.endswith("?")
    kind = kind.rstrip("?")
    if kind == "text":
        return isinstance(value, str)
    if kind == "list":
        return isinstance(value, list)
    if kind == "object":
        return isinstance(value, dict)
    if kind == "integer":
        return is_integer(value) or (is_real(value) and float(value).is_integer())
    return is_real(value)  # number


def _checked(part, entries: dict[str, str], where: str, source: str) -> dict:
    """``part`` (a record or a part of one) after checking that it is a JSON object holding each of
    ``entries`` as its kind; a DataError naming ``source`` and every entry missing, or the first
    of the wrong kind."""
    if not isinstance(part, dict):
        raise DataError(f"run record {source} is not a JSON object but {part!r:.40}; {DAMAGED}")
    missing = [f"{where}{key}" for key in entries if key not in part]
    if missing:
        raise DataError(f"run record {source} lacks {', '.join(missing)}; {DAMAGED}")
    for key, kind in entries.items():
        if not _is_kind(part[key], kind):
            wanted = KIND_NAMES[kind.rstrip("?")] + (" or null" if kind.endswith("?") else "")
            raise DataError(f"run record {source}: {where}{key} is {part[key]!r:.40}, not {wanted}; {DAMAGED}")
    return part


def _number(value) -> float:
    """A checked number entry as float, NaN for null (a run or frame without ground truth)."""
    return np.nan if value is None else float(value)


def mean_best_fitness(fitness) -> float:
    """The mean of the frames' best fitness (n,), NaN if any of them is NaN or infinite, or
    there is no frame: a mean over the other frames would compare the run with the runs of
    the same sequence on fewer frames than theirs."""
    fitness = np.asarray(fitness, dtype=float)
    return float(np.mean(fitness)) if len(fitness) and np.isfinite(fitness).all() else np.nan


def variant_names(config) -> tuple[str | None, str | None]:
    """The names of a run's optimiser settings preset (``settings.name``) and of its synthetic
    data's realism level (``dataset.realism.name``) in its resolved ``config``; None for a
    part the config does not hold (no preset named, a dataset that is not synthetic)."""

    def name(node):
        return node.get("name") if isinstance(node, dict) else None

    if not isinstance(config, dict):
        return None, None
    dataset = config.get("dataset")
    return name(config.get("settings")), name(dataset.get("realism") if isinstance(dataset, dict) else None)


def run_row(record: dict, source: str = "record") -> dict:
    """One row of the ``runs`` table from a record; ``mean_marker_error_mm`` is NaN for a run
    without ground truth, ``mean_best_fitness`` for one with a frame without a finite fitness
    (:func:`mean_best_fitness`). A record missing an entry, or with one of the wrong kind, is a
    DataError naming ``source`` and the entry."""
    record = _checked(record, RECORD_ENTRIES["record"], "", source)
    s, t, p = (
        _checked(record[part], RECORD_ENTRIES[part], f"{part}.", source)
        for part in ("summary", "timings", "provenance")
    )
    evaluation = t.get("evaluation_seconds_per_frame")
    start = s.get("start") if isinstance(s.get("start"), dict) else {}  # records before the automatic start
    settings, realism = variant_names(record.get("config"))
    keypoints = s.get("keypoints") if isinstance(s.get("keypoints"), dict) else {}  # silhouettes only, or older
    dataset = (record.get("config") or {}).get("dataset")
    turn = dataset.get("turn_deg") if isinstance(dataset, dict) else None
    return {
        "run_id": record["run_id"],
        "subject": s["subject"],
        "action": s["action"],
        "sequence": f"{s['subject']}_{s['action']}",
        "seed": int(record["seed"]),
        "optimizer": s["optimizer"],
        "strategy": s["strategy"],
        "algorithm": f"{s['optimizer']}-{s['strategy']}",
        "settings": settings,
        "realism": realism,
        "turn_deg": float(turn) if is_real(turn) else 0.0,  # type: ignore[arg-type]  # is_real: a number
        "keypoints": keypoints.get("source", "none"),  # type: ignore[union-attr]
        "keypoint_weight": float(keypoints.get("weight", 0.0)),  # type: ignore[union-attr]
        "dof": int(s["dof"]),
        "evaluations": int(s["evaluations_per_frame"]),
        "vertices": int(s["vertices"]),
        "backend": s["backend"],
        "frames": int(s["frames"]),
        "mean_marker_error_mm": _number(s["mean_marker_error_mm"]),
        "mean_best_fitness": mean_best_fitness([row[3] for row in frame_rows(record, source)]),
        "seconds_per_frame": float(t["seconds_per_frame"]),
        "evaluation_seconds_per_frame": float(evaluation) if is_real(evaluation) else np.nan,  # type: ignore[arg-type]
        "start": start.get("method", "given"),  # type: ignore[union-attr]
        "start_seconds": _number(start.get("seconds")),  # type: ignore[union-attr]
        "git_commit": p.get("git_commit"),
        "host": p.get("host"),
    }


def frame_rows(record: dict, source: str = "record") -> list[tuple[str, int, float, float]]:
    """The rows of the ``frames`` table from a checked record (:func:`run_row`): run_id, frame,
    marker_error_mm (NaN for a frame without ground truth), fitness (the frame's best, in
    [0, 1]; NaN for null)."""
    rows = []
    for k, frame in enumerate(record["frames"]):
        frame = _checked(frame, FRAME_ENTRIES, f"frames[{k}].", source)
        rows.append(
            (record["run_id"], int(frame["frame"]), _number(frame["marker_error_mm"]), _number(frame["fitness"]))
        )
    return rows


#: the runs table's columns that a run may leave empty -> why, as the warning says it
EMPTY_MEANS = {
    "mean_marker_error_mm": "have no ground truth",
    "mean_best_fitness": "have no frame, or one without a finite fitness (null, NaN or infinite)",
}


def load_runs(folder) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``(runs, frames)`` tables of every record in the store ``folder`` (see module doc). Runs
    without ground truth keep an empty ``mean_marker_error_mm``, runs with a frame without a
    finite fitness an empty ``mean_best_fitness``, each with a warning naming them."""
    store = ResultsStore(folder)
    run_ids = store.run_ids()
    if not run_ids:
        raise DataError(f"no run records in {store.records_dir}: has a sweep run into {store.folder}?")
    rows, frames, files = [], [], []
    for run_id in run_ids:
        record, source = store.get(run_id), store.path(run_id)
        rows.append(run_row(record, str(source)))  # type: ignore[arg-type]  # listed: it exists
        frames += frame_rows(record, str(source))  # type: ignore[arg-type]
        files.append(source.name)
    for column, why in EMPTY_MEANS.items():
        empty = [name for name, row in zip(files, rows) if np.isnan(row[column])]
        if empty:
            warnings.warn(
                f"{len(empty)} of {len(rows)} run(s) in {store.records_dir} {why} "
                f"({', '.join(empty[:3])}{', ...' if len(empty) > 3 else ''}): their {column} is "
                "left empty, and the statistics refuse such runs",
                MmocapWarning,
                stacklevel=2,
            )
    return pd.DataFrame(rows, columns=RUN_COLUMNS), pd.DataFrame(frames, columns=FRAME_COLUMNS)
