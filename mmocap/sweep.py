"""Hydra callback for multirun sweeps: checks, provenance, progress, export.

Configured in ``conf/config.yaml`` under ``hydra.callbacks``. For a multirun it

- checks, before any job starts, that every optimiser and evaluator the sweep names
  (``optimizer.name=...``, ``evaluator.name=...``) is installed, and that the launcher can
  run its evaluators;
- refuses to start from a source checkout with uncommitted changes when the config asks for
  a clean one (``pin.require_clean``: the paper experiments), unless ``+allow_dirty=true``;
  a single run of such an experiment too;
- writes ``sweep.json`` into the sweep folder: the number of jobs, the command-line
  overrides, the sweeper's parameters, the launcher, git commit, package versions, host,
  the checkout's changed files, and the sweep's pin (:mod:`mmocap.pin`: digests of mmocap's
  code and of every config file on Hydra's search path, plugin and package versions), taken
  when the sweep first starts in that folder and kept when it is resumed;
- refuses, before any job, to resume a sweep whose pin no longer holds, and each job (in the
  launcher's worker process) refuses to run when it does not, naming what changed;
- logs after each job how many runs of the sweep are done and about how long is left
  (jobs append a line to ``progress.jsonl``, so this works across processes and machines;
  a line torn by a crash or a full disk is skipped);
- writes ``runs.csv`` and ``frames.csv`` (:func:`mmocap.report.collect.collect`) at the end.
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
from pathlib import Path

from hydra._internal.core_plugins.basic_sweeper import BasicSweeper
from hydra.core.global_hydra import GlobalHydra
from hydra.core.hydra_config import HydraConfig
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.utils import JobReturn, JobStatus
from hydra.experimental.callback import Callback
from hydra.types import RunMode
from omegaconf import DictConfig

from mmocap import pin, provenance, registry
from mmocap.analysis.results import ResultsStore, run_key, store_folder
from mmocap.errors import ConfigError, DataError
from mmocap.io import WriteError, append_line, read_json_lines, read_json_object, write_json_atomic
from mmocap.preflight import check_config
from mmocap.report.collect import collect
from mmocap.validate import check_flag

log = logging.getLogger(__name__)


def sweep_overrides(config: DictConfig) -> dict[str, list[str]]:
    """The values each key of the sweep takes, as the basic sweeper combines them: the
    sweeper's ``params``, then the command-line overrides (later ones win)."""
    params = [f"{k}={v}" for k, v in (config.hydra.sweeper.get("params") or {}).items()]
    parsed = OverridesParser.create().parse_overrides(params + list(config.hydra.overrides.task))
    values = {}
    for override in parsed:
        key = override.get_key_element()
        if override.is_sweep_override():
            values[key] = list(override.sweep_string_iterator())
        else:
            values[key] = [override.get_value_element_as_str()]
    return values


def check_sweep(config: DictConfig, values: dict[str, list[str]]) -> None:
    """ConfigError, before any job starts, for a sweep that cannot run: an optimiser or
    evaluator name (``optimizer.name=...``, ``evaluator.name=...``) that is not installed, or
    an evaluator that starts worker processes (``starts_processes``) under the joblib
    launcher, whose worker processes cannot start a pool of their own. Config-group choices
    (``optimizer=nope``) Hydra checks itself when it composes the jobs."""
    for kind in ("optimizer", "evaluator"):
        for name in values.get(f"{kind}.name", []):
            registry.load(kind, name)
    evaluators = set(values.get("evaluator", []) + values.get("evaluator.name", [])) or {config.evaluator.name}
    launcher = config.hydra.launcher
    if "joblib" not in str(launcher.get("_target_")) or launcher.n_jobs == 1:
        return
    registered = registry.available("evaluator")
    for name in sorted(evaluators & set(registered)):
        if getattr(registry.load("evaluator", name), "starts_processes", False):
            raise ConfigError(
                f"evaluator={name} cannot start its workers inside the joblib launcher's "
                "processes: add hydra.launcher.n_jobs=1 (jobs in turn, in this process) or "
                "choose another evaluator"
            )


def job_overrides(config: DictConfig) -> list[list[str]]:
    """Each job's overrides, in the order Hydra's basic sweeper launches them."""
    params = [f"{k}={v}" for k, v in (config.hydra.sweeper.get("params") or {}).items()]
    parsed = OverridesParser.create().parse_overrides(params + list(config.hydra.overrides.task))
    return [job for batch in BasicSweeper.split_arguments(parsed, None) for job in batch]


def check_jobs(config: DictConfig) -> None:
    """ConfigError, before any job starts, for the first job of the sweep whose composed
    config fails :func:`mmocap.preflight.check_config`, naming the job and its overrides."""
    loader = GlobalHydra.instance().config_loader()
    for number, overrides in enumerate(job_overrides(config)):
        try:
            check_config(loader.load_sweep_config(config, overrides))
        except ConfigError as exc:
            raise ConfigError(f"sweep job {number} ({' '.join(overrides)}): {exc}; no job was started") from None


def config_sources(config: DictConfig) -> list[tuple[str, str]]:
    """Hydra's config search path (``hydra.runtime.config_sources``) as ``(schema, path)``
    pairs: ``("pkg", "mmocap.conf")``, ``("file", "/home/me/conf")`` ..."""
    return [(str(source.schema), str(source.path)) for source in config.hydra.runtime.config_sources]


def check_clean(config: DictConfig) -> list[str] | None:
    """The source checkout's changed files (:func:`mmocap.pin.dirty_files`; None for an
    installed wheel). ConfigError when there are some and the config asks for a clean
    checkout (``pin.require_clean``: the paper experiments) without ``+allow_dirty=true``."""
    required = check_flag("pin.require_clean", config.pin.require_clean)
    allowed = check_flag("allow_dirty", config.get("allow_dirty", False))
    dirty = pin.dirty_files()
    if dirty and required and not allowed:
        raise ConfigError(
            f"pin.require_clean is set (a paper experiment), but the checkout has uncommitted changes "
            f"({pin.named(dirty)}): commit them, or add +allow_dirty=true to run anyway (sweep.json "
            "and the records then say so)"
        )
    return dirty


def pin_refused(found: list[str], sweep_dir: Path | str) -> str:
    """The one line that refuses a job or a resumed sweep whose pin no longer holds."""
    change = "the change" if len(found) == 1 else "the changes"
    return (
        f"{pin.named(found)} changed since the sweep in {sweep_dir} started: undo {change} and run the same "
        f"command to finish the sweep, or start it again (delete {sweep_dir}, or sweep into another folder: "
        "hydra.sweep.dir=...)"
    )


def pinned(sweep_dir: Path) -> dict | None:
    """The pin recorded in ``sweep_dir/sweep.json`` (None without one: a new sweep, or one
    started before sweeps were pinned)."""
    info_path = sweep_dir / "sweep.json"
    return read_json_object(info_path).get("pin") if info_path.is_file() else None


def check_pin(config: DictConfig, sweep_dir: Path) -> dict:
    """The pin of the sweep in ``sweep_dir``: the one recorded there, if this process's
    (:func:`mmocap.pin.take`) is the same, else a ConfigError naming what changed; this
    process's where none is recorded."""
    now = pin.take(config_sources(config))
    recorded = pinned(sweep_dir)
    if recorded is not None and (found := pin.changes(recorded, now)):
        raise ConfigError(pin_refused(found, sweep_dir))
    return recorded or now


class SweepProgress(Callback):
    """Provenance, pin, progress and export of a multirun sweep (see module doc)."""

    def on_run_start(self, config: DictConfig, **kwargs) -> None:
        if config.pin.require_clean:
            check_clean(config)

    def on_multirun_start(self, config: DictConfig, **kwargs) -> None:
        sweep_dir = Path(config.hydra.sweep.dir)
        values = sweep_overrides(config)
        check_sweep(config, values)
        check_jobs(config)
        dirty = check_clean(config)
        kept = check_pin(config, sweep_dir)
        total = math.prod(len(v) for v in values.values())
        sweep_dir.mkdir(parents=True, exist_ok=True)
        store = ResultsStore(store_folder(config, sweep_dir))
        already = len(store.run_ids())
        info = {
            "session": f"{provenance.now()}-{os.getpid()}",
            "started": time.time(),
            "jobs": total,
            "store": str(store.folder),
            "overrides": list(config.hydra.overrides.task),
            "sweeper_params": {k: str(v) for k, v in (config.hydra.sweeper.get("params") or {}).items()},
            "launcher": config.hydra.launcher.get("_target_"),
            "provenance": provenance.facts(),
            "dirty_files": dirty,
            "allow_dirty": bool(config.get("allow_dirty", False)),
            "pin": kept,
        }
        write_json_atomic(sweep_dir / "sweep.json", info)
        log.info("sweep of %d runs into %s (%d records already in the store)", total, sweep_dir, already)

    def on_job_start(self, config: DictConfig, **kwargs) -> None:
        if HydraConfig.get().mode != RunMode.MULTIRUN:
            return
        check_pin(config, Path(HydraConfig.get().sweep.dir))
        run_id = run_key(config)
        stores = [store_folder(config, HydraConfig.get().sweep.dir), *config.results.reuse]  # type: ignore[arg-type]  # a str folder
        self.found = any(ResultsStore(folder).path(run_id).is_file() for folder in stores)

    def on_job_end(self, config: DictConfig, job_return: JobReturn, **kwargs) -> None:
        if HydraConfig.get().mode != RunMode.MULTIRUN:
            return
        sweep_dir = Path(HydraConfig.get().sweep.dir)
        info_path = sweep_dir / "sweep.json"
        if not info_path.is_file():
            return
        info = read_json_object(info_path)
        ran = not self.found and job_return.status == JobStatus.COMPLETED and self.recorded_here(config)
        line = {
            "session": info["session"],
            "job": HydraConfig.get().job.num,
            "status": job_return.status.name,
            "ran": ran,
        }
        try:
            append_line(sweep_dir / "progress.jsonl", json.dumps(line))
        except WriteError as exc:  # the job's record, not this line, makes it count: the sweep goes on
            log.warning("sweep progress not shown: %s", exc)
            return
        log.info(progress_line(sweep_dir / "progress.jsonl", info))

    @staticmethod
    def recorded_here(config: DictConfig) -> bool:
        """Whether this job's run folder made the run's record: not so for a job that waited for
        the record of another sweep running the same run into a shared store."""
        record = ResultsStore(store_folder(config, Path(str(HydraConfig.get().sweep.dir)))).get(run_key(config))
        return record is not None and Path(record["output_dir"]) == Path(HydraConfig.get().runtime.output_dir)

    def on_multirun_end(self, config: DictConfig, **kwargs) -> None:
        folder = store_folder(config, config.hydra.sweep.dir)
        if ResultsStore(folder).run_ids():
            runs_csv, frames_csv = collect(folder)
            log.info("sweep done: %s, %s", runs_csv, frames_csv)


def progress_line(progress_file: Path, info: dict) -> str:
    """The line "k/N runs done, about T left" for the sweep session ``info``, from the lines of
    ``progress_file`` (a line torn by a crash or a full disk is skipped)."""
    mine = [line for line in read_json_lines(progress_file) if line.get("session") == info["session"] and "job" in line]
    done = len({line["job"] for line in mine})
    ran = sum(line.get("ran") is True for line in mine)
    total = info["jobs"]
    elapsed = time.time() - info["started"]
    text = f"sweep: {done}/{total} runs done ({done - ran} found in the store)"
    if ran and done < total:
        text += f", about {format_seconds(elapsed / ran * (total - done))} left"
    return text + f", {format_seconds(elapsed)} elapsed"


def unfinished_jobs(sweep_dir: Path, jobs: list[list[str]]) -> list[str]:
    """The jobs of the sweep session of ``sweep_dir/sweep.json`` that did not end completed (no
    line of ``progress.jsonl`` says so: their worker died, they failed, or the sweep stopped
    first), each as "#<job number> (<the overrides that set it apart from the other jobs>)";
    ``jobs`` holds every job's overrides in launch order (:func:`job_overrides`). Empty without
    a ``sweep.json``."""
    try:
        session = read_json_object(sweep_dir / "sweep.json")["session"]
        lines = read_json_lines(sweep_dir / "progress.jsonl") if (sweep_dir / "progress.jsonl").is_file() else []
    except (DataError, KeyError):  # no readable sweep.json: no session to name jobs of
        return []
    done = {line.get("job") for line in lines if line.get("session") == session and line.get("status") == "COMPLETED"}
    shared = set.intersection(*(set(job) for job in jobs)) if len(jobs) > 1 else set()
    return [
        f"#{number} ({' '.join(o for o in job if o not in shared) or 'no overrides'})"
        for number, job in enumerate(jobs)
        if number not in done
    ]


def format_seconds(seconds: float) -> str:
    """3725 -> '1 h 02 min', 125 -> '2 min 05 s', 7 -> '7 s'."""
    seconds = int(round(seconds))
    if seconds >= 3600:
        return f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"
    if seconds >= 60:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds} s"
