"""Results store: one record per finished run, kept in a store that makes sweeps resumable.

A store is a folder (a sweep's folder, or a single run's) holding ``records/<run_id>.json``
and ``store.json`` (the schema of its records). A record is written once, atomically (a
temporary file in ``records/`` then ``os.replace``: the store needs a file system whose
rename within a folder is atomic), when its run finishes: a run killed midway leaves no
record and is run again by the next sweep, a finished run is never run twice. ``run_id`` is
a digest of the run's resolved config without what does not change its result (output
paths, progress bars, overlays, the ``scale`` presets, the name of the ``settings`` preset
(its optimiser values stay in the key), ``run_dir_busy``, Hydra's own settings), and without
the keys added since the first records while they hold their neutral values
(:data:`ADDED_KEYS`).

A record carries the schema of its layout and key rules (``schema``, :data:`SCHEMA`; none
in the records made before it existed: :data:`FIRST_SCHEMA`). A job refuses a store of
another schema, whose runs it would not find, and :func:`load_runs` a store that mixes them;
``mmocap store migrate`` (:mod:`mmocap.analysis.migration`) brings one to :data:`SCHEMA`.

Several jobs may write into one store at once (two sweeps sharing ``results.store``): a job
claims its run (:meth:`ResultsStore.claim`) before running it, and a job that finds the run
claimed waits for the claim's holder to end, then finds its record instead of running it.

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

import fcntl
import fnmatch
import hashlib
import json
import logging
import os
import socket
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from omegaconf import DictConfig, OmegaConf

from mmocap import provenance
from mmocap.analysis.statistics import overflow_free_mean
from mmocap.data.realism import DETECTOR_SETTINGS
from mmocap.errors import DataError, MmocapWarning
from mmocap.io import read_json_object, write_json_atomic, writing
from mmocap.validate import is_integer, is_real

log = logging.getLogger(__name__)

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


#: a config key that the config does not hold (a value of :attr:`AddedKey.neutral`)
ABSENT = object()


@dataclass(frozen=True)
class AddedKey:
    """A config key added after records were made without it, and its neutral values: those
    at which a run is the run it was before the key existed. While the key holds one of them,
    it stays out of the run's key, and so does what such a run does not read (``drops``), so
    that the records made before keep their keys.

    ``key`` and the paths of ``drops`` are dotted paths into the resolved config, outside
    :data:`NOT_IN_KEY`; the last part of a path in ``drops`` may be a glob pattern
    (``start.keypoint_*``), and ``drops`` left empty means the key alone. A value is neutral
    when it equals (``==``) one of ``neutral``; :data:`ABSENT` there stands for a config that
    lacks the key."""

    key: str
    neutral: tuple
    drops: tuple[str, ...] = ()

    def left_out(self, config: dict) -> tuple[str, ...]:
        """The paths this rule leaves out of the key of the resolved ``config``: ``drops`` (or
        the key) when the key's value is neutral, else none."""
        value = _lookup(config, self.key)
        return (self.drops or (self.key,)) if any(value == neutral for neutral in self.neutral) else ()


#: every config key added after the first records were made, with its neutral values: the one
#: place a new block or setting is declared so that it does not move the keys of older records
#: (a block is declared through a setting that turns it off, dropping the whole block). A key
#: that no neutral value can keep out moves keys: that needs a new :data:`SCHEMA` instead.
ADDED_KEYS = (
    # multi-fidelity search: without levels, an exact search as before
    AddedKey("fidelity.levels", (ABSENT, None, []), drops=("fidelity",)),
    # the synthetic motion turned about the vertical: not turned, the sequence as before
    AddedKey("dataset.turn_deg", (0,)),
    # 2-D keypoints in the fitness: without them (silhouettes only), a run reads neither the
    # keypoint settings, nor the realism's simulated detector, nor the start's keypoint settings
    AddedKey(
        "keypoints.source",
        ("none",),
        drops=(
            "keypoints",
            *(f"realism.{setting}" for setting in DETECTOR_SETTINGS),
            *(f"dataset.realism.{setting}" for setting in DETECTOR_SETTINGS),
            "start.keypoint_*",
        ),
    ),
    # the OpenCL evaluators' cap on local memory (masks in bands): without a cap, the device's
    AddedKey("evaluator.max_local_bytes", (ABSENT, None)),
)


def _lookup(config: dict, path: str):
    """The value at the dotted ``path`` of the nested dict ``config``, :data:`ABSENT` if none."""
    node: Any = config
    for part in path.split("."):
        if not isinstance(node, dict) or part not in node:
            return ABSENT
        node = node[part]
    return node


def _drop(config: dict, path: str) -> None:
    """Remove the entries at the dotted ``path`` (its last part a glob pattern) of ``config``."""
    *parents, pattern = path.split(".")
    node: Any = config
    for part in parents:
        node = node.get(part) if isinstance(node, dict) else None
    if isinstance(node, dict):
        for key in [k for k in node if fnmatch.fnmatchcase(str(k), pattern)]:
            del node[key]


def key_config(cfg: DictConfig) -> dict:
    """The resolved config that identifies a run: everything but ``NOT_IN_KEY``, less what the
    rules of :data:`ADDED_KEYS` leave out (keys added since the first records, at their neutral
    values), so that the records made before those keys existed still match."""
    kept: dict[str, Any] = {}
    for key in cfg:
        if key not in NOT_IN_KEY:
            node = cfg[key]  # interpolations resolve against the whole config
            kept[str(key)] = OmegaConf.to_container(node, resolve=True) if OmegaConf.is_config(node) else node
    left_out = [path for added in ADDED_KEYS for path in added.left_out(kept)]  # decided before any is dropped
    for path in left_out:
        _drop(kept, path)
    return kept


def run_key(cfg: DictConfig) -> str:
    """16 hex digits identifying the run ``cfg`` describes (same config, same key)."""
    text = json.dumps(key_config(cfg), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def store_folder(cfg: DictConfig, fallback: Path) -> Path:
    """The results store of a run: ``results.store`` if set, else ``fallback`` (the
    sweep folder in a multirun, the run's own folder otherwise)."""
    return Path(cfg.results.store if cfg.results.store is not None else fallback)


#: the schema of the records a store holds: their layout and the rules of :func:`run_key`
#: that named them. A record without ``schema`` is of :data:`FIRST_SCHEMA`, made before
#: records had one. Raise it when a change moves the key of a config that records hold (the
#: golden keys in ``tests/golden/data/run_keys_schema_<SCHEMA>.json`` say so) and cannot be
#: declared in :data:`ADDED_KEYS`; ``mmocap store migrate`` (:mod:`mmocap.analysis.migration`)
#: then renames the records of older stores.
SCHEMA = 1
FIRST_SCHEMA = 1
#: the store's own file, beside ``records/``: ``{"schema": N}``, written when its first record is
STORE_FILE = "store.json"


def migrate_hint(folder) -> str:
    """How to bring the store ``folder`` to :data:`SCHEMA`."""
    return f"run `mmocap store migrate {folder}` to bring them to schema {SCHEMA}"


def record_schema(record: dict, source) -> int:
    """The schema of ``record`` (read from ``source``): its ``schema``, :data:`FIRST_SCHEMA` if it
    has none; a DataError for one that is not a whole number from FIRST_SCHEMA on, or that is
    newer than this mmocap's :data:`SCHEMA`."""
    schema = record.get("schema", FIRST_SCHEMA) if isinstance(record, dict) else FIRST_SCHEMA
    if not is_integer(schema) or int(schema) < FIRST_SCHEMA:
        raise DataError(
            f"run record {source}: schema is {schema!r:.40}, not a whole number from {FIRST_SCHEMA}; {DAMAGED}"
        )
    if int(schema) > SCHEMA:
        raise DataError(
            f"run record {source} is of schema {schema}, newer than this mmocap's {SCHEMA}: "
            "read it with the mmocap that wrote it (its provenance.versions says which) or upgrade mmocap"
        )
    return int(schema)


class ResultsStore:
    """The records of finished runs under ``folder/records/``, the store's schema in
    ``folder/store.json``, and the claims of the runs being run (see module doc)."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self.records_dir = self.folder / "records"
        self.store_file = self.folder / STORE_FILE

    def path(self, run_id: str) -> Path:
        """The record file of ``run_id``: ``records/<run_id>.json`` in the store's folder."""
        return self.records_dir / f"{run_id}.json"

    def claim_path(self, run_id: str) -> Path:
        """The claim file of ``run_id``: ``records/.<run_id>.claim``, there while a job runs it."""
        return self.records_dir / f".{run_id}.claim"

    def get(self, run_id: str) -> dict | None:
        """The record of ``run_id``, or None if that run has not finished here."""
        path = self.path(run_id)
        if not path.is_file():
            return None
        return read_json_object(path, name=f"run record {path}", fix="delete it to run again")

    def schema(self) -> int | None:
        """The schema of the store's records: its ``store.json``'s; :data:`FIRST_SCHEMA` for a
        store with records but no ``store.json`` (made before stores had a schema); None for an
        empty store."""
        if not self.store_file.is_file():
            return FIRST_SCHEMA if self.run_ids() else None
        fix = f'write {{"schema": N}} into it, N the schema of its records ({FIRST_SCHEMA} for those without one)'
        schema: Any = read_json_object(self.store_file, fix=fix).get("schema")
        if not is_integer(schema) or int(schema) < FIRST_SCHEMA:
            raise DataError(f"{self.store_file}: schema is {schema!r:.40}, not a whole number; {fix}")
        return int(schema)

    def check_schema(self) -> None:
        """A DataError, naming the store, if its records are of another schema than this
        mmocap's :data:`SCHEMA`: their keys are not those this mmocap gives its runs, so a
        finished run would not be found there."""
        schema = self.schema()
        if schema is None or schema == SCHEMA:
            return
        if schema > SCHEMA:
            raise DataError(
                f"results store {self.folder} is of schema {schema} ({self.store_file}), newer than this "
                f"mmocap's {SCHEMA}: use the mmocap that wrote it, or another results.store"
            )
        raise DataError(
            f"results store {self.folder} holds records of schema {schema}, keyed by older rules than this "
            f"mmocap's (schema {SCHEMA}): {migrate_hint(self.folder)}, or use another results.store"
        )

    def set_schema(self, schema: int) -> None:
        """Write ``store.json`` saying the store's records are of ``schema``, atomically."""
        write_json_atomic(self.store_file, {"schema": schema})

    def clear_unfinished(self, run_id: str) -> None:
        """Remove what an interrupted write of ``run_id``'s record left (its temporaries);
        called by the job that holds ``run_id``'s claim (:meth:`claim`), the only writer of
        that record."""
        for path in self.records_dir.glob(f".{run_id}.json.*.tmp"):
            path.unlink(missing_ok=True)

    @contextmanager
    def claim(self, run_id: str) -> Iterator[None]:
        """Hold the claim of ``run_id`` for the block: while a job holds it, no other job runs
        that run. Where another process holds it, log so and wait until that process ends
        (its record written, or it failed or was killed: the kernel then releases its lock,
        and the claim it left is taken over), then hold it.

        The claim is the file ``records/.<run_id>.claim`` holding an exclusive ``flock`` lock
        and the holder's process, host and start; it is removed when the block ends. A waiter
        whose claim file was removed meanwhile claims the new one (the inode is checked)."""
        path = self.claim_path(run_id)
        with writing(path):
            self.records_dir.mkdir(parents=True, exist_ok=True)
        while True:
            with writing(path):
                fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "another process"
                log.info("run %s is being run by %s (%s): waiting for its record", run_id, holder, path)
                fcntl.flock(fd, fcntl.LOCK_EX)
            if _same_file(fd, path):
                break
            os.close(fd)  # its holder removed that claim: claim the file there now
        try:
            with writing(path):
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"process {os.getpid()} on {socket.gethostname()} since {provenance.now()}\n".encode(), 0)
            yield
        finally:
            path.unlink(missing_ok=True)  # while locked: a waiter that gets this file sees it is gone
            os.close(fd)

    def put(self, record: dict) -> Path:
        """Write ``record`` atomically (and ``store.json``, with the record's schema, if the
        store has none yet); returns its path."""
        self.records_dir.mkdir(parents=True, exist_ok=True)
        if not self.store_file.is_file():
            self.set_schema(record_schema(record, self.path(record["run_id"])))
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


def _same_file(fd: int, path: Path) -> bool:
    """Whether the open file ``fd`` is the file at ``path`` (not removed or replaced since)."""
    try:
        return os.path.samestat(os.fstat(fd), os.stat(path))
    except FileNotFoundError:
        return False


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
        "schema": SCHEMA,
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
    the same sequence on fewer frames than theirs. The mean is correctly rounded
    (:func:`~mmocap.analysis.statistics.overflow_free_mean`), so runs whose frames' fitness has
    equal exact means tie in the statistics whatever the frames' order."""
    fitness = np.asarray(fitness, dtype=float)
    return overflow_free_mean(fitness) if len(fitness) and np.isfinite(fitness).all() else np.nan


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
    schemas: dict[int, Path] = {}  # schema -> the first record of it
    for run_id in run_ids:
        record, source = store.get(run_id), store.path(run_id)
        rows.append(run_row(record, str(source)))  # type: ignore[arg-type]  # listed: it exists
        frames += frame_rows(record, str(source))  # type: ignore[arg-type]
        files.append(source.name)
        schemas.setdefault(record_schema(record, source), source)  # type: ignore[arg-type]
    if len(schemas) > 1:
        mixed = " and ".join(f"schema {schema} ({path.name})" for schema, path in sorted(schemas.items()))
        raise DataError(
            f"results store {store.folder} mixes records of {mixed}, keyed by different rules: "
            f"{migrate_hint(store.folder)}"
        )
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
