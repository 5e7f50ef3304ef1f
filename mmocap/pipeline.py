"""The main job: build every stage from the config, track a sequence, write the results.

Outputs in ``output_dir`` (their names: :mod:`mmocap.run_folder`): ``frames.csv`` (one row
per frame, written as it goes), ``traces.csv`` (each frame's convergence:
:mod:`mmocap.writers.traces`), the exports, ``error_per_frame.png``, ``overlays/*.png``, the
videos (:mod:`mmocap.writers`) and ``summary.json``; and the run's record in
the results store (:mod:`mmocap.analysis.results`). A run whose record is already in the
store, or in one of ``results.reuse``, is not run again. A job claims its run in the store
before running it; a job that finds the run claimed by another (two sweeps into one store)
waits for that one's record instead of running it too.

What a stopped run leaves (the rule of :mod:`mmocap.io`: a file appears under its final
name only when complete): every file is written atomically, except the per-frame rows,
which go to ``frames.csv.partial`` until the last frame is tracked and it is renamed
``frames.csv``. ``summary.json`` is written after every other output, and the record after
it: a run folder without ``summary.json`` holds an incomplete run, which has no record and
runs again. A run first removes what an earlier unrecorded run left in its folder.

One run at a time writes into a run folder: a run holds the lock ``<output_dir>/.run.lock``
while it runs. Another run into the same folder stops with an error, or waits for the lock
with ``run_dir_busy=wait``.
"""

from __future__ import annotations

import logging
import warnings
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from tqdm.auto import tqdm

from mmocap import provenance
from mmocap.analysis.results import ResultsStore, make_record, mean_best_fitness, run_key, store_folder
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.evaluators.timed import TimedEvaluator
from mmocap.io import LockBusyError, exclusive, locked, writing
from mmocap.preflight import check_config
from mmocap.run_folder import ERROR_PLOT, EXPORT_FOLDER, FRAMES, OVERLAYS, RUN_LOCK, RUN_OUTPUTS, TRACES, Summary
from mmocap.stages.accuracy import FrameLog, marker_error
from mmocap.stages.foreground import Foreground, choose_method
from mmocap.stages.keypoints import KeypointStream
from mmocap.stages.tracking import track
from mmocap.writers.export import export_motion, exported_files, read_poses
from mmocap.writers.overlays import write_overlays
from mmocap.writers.plots import plot_error_per_frame
from mmocap.writers.traces import write_traces
from mmocap.writers.videos import run_video_files, write_run_videos

log = logging.getLogger(__name__)


@contextmanager
def recorded_warnings():
    """Yields the list that collects the messages of every :class:`MmocapWarning` shown in
    the block; each is still shown as usual."""
    messages: list[str] = []
    shown = warnings.showwarning

    def show(message, category, *args, **kwargs):
        if issubclass(category, MmocapWarning):
            messages.append(str(message))
        shown(message, category, *args, **kwargs)

    warnings.showwarning = show
    try:
        yield messages
    finally:
        warnings.showwarning = shown


def run(cfg: DictConfig, output_dir: Path) -> dict:
    """Run the configured tracking job; returns the summary written to summary.json (or,
    for a run already in the results store, the summary of its record). The summary's
    ``warnings`` lists every :class:`MmocapWarning` the run gave."""
    output_dir = Path(output_dir)
    check_config(cfg)  # every value, before anything is read or written
    wait = cfg.run_dir_busy == "wait"
    with recorded_warnings() as messages, run_folder_lock(output_dir, wait):
        return _run(cfg, output_dir, messages)


@contextmanager
def run_folder_lock(output_dir: Path, wait: bool):
    """Hold the lock of the run folder ``output_dir`` (created if need be) for the block; if
    another run holds it, wait for it to finish (``wait``) or raise a DataError naming the
    folder and that run."""
    with ExitStack() as stack:
        try:
            stack.enter_context(locked(output_dir / RUN_LOCK, wait=wait))
        except LockBusyError as busy:
            raise DataError(
                f"run folder {output_dir} is in use by another run ({busy.holder}): wait for it "
                "to finish, use another hydra.run.dir, or set run_dir_busy=wait to wait for it"
            ) from None
        yield


def clear_outputs(output_dir: Path) -> None:
    """Remove what an earlier run that left no record wrote into ``output_dir`` (its
    :data:`~mmocap.run_folder.RUN_OUTPUTS`, overlays, exports, videos and temporary files), so
    that no file of another run lies beside this run's."""
    overlays = output_dir / OVERLAYS
    with writing(output_dir):
        for path in [
            *(output_dir / name for name in RUN_OUTPUTS),
            *output_dir.glob(".*.tmp"),
            *overlays.glob("frame_*.png"),
            *overlays.glob(".*.tmp"),
            *exported_files(output_dir / EXPORT_FOLDER),
            *run_video_files(output_dir),
        ]:
            path.unlink(missing_ok=True)


@dataclass
class Components:
    """The parts of a run, built from the config groups of the same names
    (:func:`build_components`); ``start`` is the automatic start (``start:``), ``evaluator``
    times its calls, ``body`` is replaced by the fitted one when an automatic start fits it, and
    ``plausibility`` warns when the fit explains the foreground poorly."""

    optimizer: Any
    strategy: Any
    evaluator: TimedEvaluator
    body: Any
    coverage: Any
    start: Any
    recovery: Any
    fidelity: Any
    plausibility: Any
    keypoints: Any


@dataclass
class Tracking:
    """What tracking the frames gave: the FrameResults in order, each frame's marker error
    (mm, NaN where the frame has no ground truth) and the record's rows of the frames
    (:func:`mmocap.analysis.results.make_record`)."""

    results: list
    errors_mm: list[float]
    frame_rows: list[dict]

    @property
    def search_seconds(self) -> float:
        """The wall time of the frames' searches, s."""
        return sum(r.seconds for r in self.results)

    @property
    def foreground_seconds(self) -> float:
        """The time spent reading the frames' foreground, s."""
        return sum(r.foreground_seconds for r in self.results)

    @property
    def mean_silhouette_fitness(self) -> float:
        """The mean of the frames' best poses' silhouette fitness (their best fitness when it
        has no keypoint term)."""
        return mean_best_fitness(
            [r.fitness if r.silhouette_fitness is None else r.silhouette_fitness for r in self.results]
        )

    @property
    def mean_best_fitness(self) -> float:
        """The mean of the frames' best fitness (NaN if one is not finite)."""
        return mean_best_fitness([row["fitness"] for row in self.frame_rows])


def _run(cfg: DictConfig, output_dir: Path, warning_messages: list[str]) -> dict:
    """:func:`run`, in the locked run folder ``output_dir``: the summary's ``warnings`` is
    ``warning_messages``. A run whose record is in the store (or in ``results.reuse``) is
    found, not run; one that another job is running is waited for and then found (its claim:
    :meth:`~mmocap.analysis.results.ResultsStore.claim`); a store of another schema is
    refused."""
    output_dir.mkdir(parents=True, exist_ok=True)
    store = ResultsStore(store_folder(cfg, sweep_folder() or output_dir))
    run_id = run_key(cfg)
    for folder in [store.folder, *cfg.results.reuse]:
        ResultsStore(folder).check_schema()  # records keyed by other rules would not be found
    done = finished_summary(store, run_id, cfg.results.reuse)
    if done is not None:
        return done
    with store.claim(run_id):  # waits while another job runs it
        done = finished_summary(store, run_id, cfg.results.reuse)  # that job finished it meanwhile
        if done is not None:
            return done
        return _track(cfg, output_dir, store, run_id, warning_messages)


def _track(cfg: DictConfig, output_dir: Path, store: ResultsStore, run_id: str, warning_messages: list[str]) -> dict:
    """Track the run ``run_id`` into ``output_dir`` and put its record into ``store``, whose
    claim of it the caller holds; returns the summary."""
    clear_outputs(output_dir)
    store.clear_unfinished(run_id)
    started = provenance.now()
    parts = build_components(cfg)  # first: a bad value fails before any data is rendered or read
    sequence, truth, foreground = open_sequence(cfg, parts.body)
    keypoints = parts.keypoints.open(sequence, foreground)
    rng = np.random.default_rng(int(cfg.seed))
    x0, start_facts = find_start(cfg, parts, sequence, foreground, rng, keypoints)
    tracking = track_frames(cfg, output_dir, parts, sequence, foreground, truth, x0, rng, keypoints)
    parts.plausibility.check_run(tracking.mean_silhouette_fitness)
    summary = make_summary(cfg, run_id, parts, sequence, tracking, start_facts, warning_messages)
    if keypoints is not None:
        summary.keypoints = {**keypoints.summary(), "mean_silhouette_fitness": tracking.mean_silhouette_fitness}
    write_outputs(cfg, output_dir, parts, sequence, foreground, truth, tracking, summary)
    summary.write(output_dir)  # the last output: the run is complete
    parts.evaluator.close()
    parts.fidelity.close()
    path = store.put(
        make_record(
            cfg,
            summary.to_json(),
            tracking.frame_rows,
            tracking.search_seconds,
            parts.evaluator.seconds,
            tracking.foreground_seconds,
            started,
            output_dir,
        )
    )
    log.info("run %s recorded in %s", run_id, path)
    return summary.to_json()


def finished_summary(store: ResultsStore, run_id: str, reuse) -> dict | None:
    """The summary of the record of ``run_id`` in ``store``, or in the first of the stores
    ``reuse`` that has it (copied into ``store``); None if the run has not finished."""
    done = store.get(run_id) or store.adopt(run_id, reuse)
    if done is None:
        return None
    log.info(
        "run %s already finished (record %s): skipped; delete the record to run it again", run_id, store.path(run_id)
    )
    return done["summary"]


def build_components(cfg: DictConfig) -> Components:
    """The run's components from the config, checked against each other (the strategy against
    the body, optimiser and budget; the fidelity levels against the strategy)."""
    parts = Components(
        optimizer=instantiate(cfg.optimizer),
        strategy=instantiate(cfg.strategy),
        evaluator=TimedEvaluator(instantiate(cfg.evaluator)),
        body=instantiate(cfg.body),
        coverage=instantiate(cfg.coverage),
        start=instantiate(cfg.start),
        recovery=instantiate(cfg.recovery),
        fidelity=instantiate(
            cfg.fidelity,
            evaluator=lambda: instantiate(cfg.evaluator),
            optimizer=lambda **settings: instantiate(cfg.optimizer, **settings),
        ),
        plausibility=instantiate(cfg.plausibility),
        keypoints=instantiate(cfg.keypoints),
    )
    parts.strategy.check(parts.body, parts.optimizer, int(cfg.tracking.evaluations))
    parts.fidelity.check(parts.strategy)
    return parts


def open_sequence(cfg: DictConfig, body) -> tuple[Any, np.ndarray, Foreground]:
    """The configured sequence (rendered first if need be, once among parallel jobs), the
    ground truth of the frames to track ((frames, M, 3) mm, NaN where a frame has none) and
    its foreground; a ConfigError if the sequence shows another subject than ``body``'s."""
    dataset = instantiate(cfg.dataset)
    with exclusive(getattr(dataset, "path", None)):  # parallel jobs render a sequence once
        sequence = dataset.open(progress=cfg.progress)
    if sequence.subject is not None and body.subject.name != sequence.subject:
        raise ConfigError(f"body.subject is {body.subject.name} but the sequence shows {sequence.subject}")
    n_frames = sequence.n_frames if cfg.tracking.frames is None else int(cfg.tracking.frames)
    truth = sequence.ground_truth(n_frames, str(cfg.evaluation.missing_markers))
    return sequence, truth, open_foreground(cfg, sequence, cache_dir=cfg.foreground_cache)


def open_foreground(cfg: DictConfig, sequence, cache_dir) -> Foreground:
    """The foreground of ``sequence`` by the method ``foreground.method`` chooses (logged)."""
    make_model, reason = choose_method(
        sequence,
        str(cfg.foreground.method),
        instantiate(cfg.background),
        instantiate(cfg.foreground.segmentation),
        instantiate(cfg.foreground.masks),
    )
    log.info("foreground: %s", reason)
    return Foreground(sequence, make_model, cache_dir=cache_dir, method=reason)


def find_start(
    cfg: DictConfig,
    parts: Components,
    sequence,
    foreground: Foreground,
    rng: np.random.Generator,
    keypoints: KeypointStream | None = None,
) -> tuple[np.ndarray | None, dict]:
    """Warm the evaluators up and find the first frame's pose: the sequence's own (``x0``,
    mm and rad), or, when the automatic start is wanted, the one it finds (its body, fitted,
    replaces ``parts.body``), from the first frame's ``keypoints`` too when there are any and
    ``keypoints.use_for_start``. Returns the start pose (None: the tracker's default) and the
    facts the summary records about it."""
    x0, start_facts = sequence.x0, {"method": "given"}
    start_pose = parts.body.rest_pose() if x0 is None else x0
    # once: without a cache, each call reads and segments the frame again
    first_masks, first_landmarks = foreground.detections(0)
    parts.evaluator.warm_up(parts.body, foreground.cameras, first_masks, start_pose)
    parts.fidelity.warm_up(parts.body, foreground.cameras, first_masks, start_pose)
    if parts.start.wanted(has_x0=x0 is not None):
        use_keypoints = keypoints is not None and parts.keypoints.use_for_start
        found = parts.start.find(
            parts.body,
            foreground.cameras,
            first_masks,
            parts.evaluator,
            parts.optimizer,
            parts.strategy,
            rng,
            fit_height=cfg.body.get("height_mm") is None,
            fit_girth=cfg.body.get("girth") is None,
            keypoints=keypoints.frame(0, first_landmarks) if use_keypoints else None,  # type: ignore[union-attr]
        )
        parts.body, x0, start_facts = found.body, found.pose, found.summary()
        parts.plausibility.check_start(found)
        parts.evaluator.seconds = 0.0  # the tracking's evaluation time from here on; the start's is in start_facts
        log.info(
            "automatic start: %.1f s, %d evaluations; body %.0f mm tall, girth %.2f",
            found.seconds,
            found.evaluations,
            parts.body.subject.height_mm,
            parts.body.subject.girth,
        )
    return x0, start_facts


def track_frames(
    cfg: DictConfig,
    output_dir: Path,
    parts: Components,
    sequence,
    foreground: Foreground,
    truth: np.ndarray,
    x0: np.ndarray | None,
    rng: np.random.Generator,
    keypoints: KeypointStream | None = None,
) -> Tracking:
    """Track the frames of ``truth`` ((frames, M, 3) mm) from ``x0``, with each frame's
    ``keypoints`` in the fitness when there are any, writing each frame's row to
    ``frames.csv`` as it is tracked (``frames.csv.partial`` until the last one, where a
    stopped run leaves it)."""
    body = parts.body
    frame_log = FrameLog(output_dir / FRAMES)
    tracking = Tracking([], [], [])
    bar = tqdm(total=len(truth), desc=f"track {cfg.optimizer.name}", unit="frame", disable=not cfg.progress)

    def on_frame(result):
        err = float(marker_error(body.markers(result.pose[None]), truth[result.frame][None])[0])
        tracking.errors_mm.append(err)
        tracking.frame_rows.append(
            {
                "frame": int(result.frame),
                "marker_error_mm": err,
                "fitness": float(result.fitness),
                "evaluations": int(result.evaluations),
                "seconds": float(result.seconds),
                "foreground_seconds": float(result.foreground_seconds),
            }
        )
        frame_log.write(result.frame, err, result.fitness, result.evaluations, result.seconds, result.pose)
        scored_so_far = [e for e in tracking.errors_mm if not np.isnan(e)]
        bar.set_postfix(error_mm=f"{err:.1f}", mean_mm=f"{np.mean(scored_so_far):.1f}" if scored_so_far else "-")
        bar.update()

    try:
        tracking.results = track(
            sequence,
            body,
            foreground,
            parts.evaluator,
            parts.optimizer,
            parts.strategy,
            evaluations=int(cfg.tracking.evaluations),
            seed=int(cfg.seed),
            frames=cfg.tracking.frames,
            on_frame=on_frame,
            coverage=parts.coverage,
            x0=x0,
            rng=rng,
            recovery=parts.recovery,
            fidelity=parts.fidelity,
            keypoints=keypoints,
        )
    except BaseException:
        frame_log.close(complete=False)  # the frames tracked stay in frames.csv.partial
        raise
    finally:
        bar.close()
    frame_log.close()
    return tracking


def make_summary(
    cfg: DictConfig,
    run_id: str,
    parts: Components,
    sequence,
    tracking: Tracking,
    start_facts: dict,
    warning_messages: list[str],
) -> Summary:
    """The run's summary. Its ``warnings`` is ``warning_messages`` itself, so that it holds the
    warnings given until it is written."""
    errors = np.asarray(tracking.errors_mm)
    scored = errors[~np.isnan(errors)]  # frames with ground truth; the statistics are over them, null if none
    frames = len(tracking.results)
    body = parts.body
    return Summary(
        mean_marker_error_mm=float(np.mean(scored)) if scored.size else None,
        median_marker_error_mm=float(np.median(scored)) if scored.size else None,
        max_marker_error_mm=float(np.max(scored)) if scored.size else None,
        mean_best_fitness=float(tracking.mean_best_fitness) if np.isfinite(tracking.mean_best_fitness) else None,
        frames=frames,
        frames_scored=int(scored.size),
        evaluations_per_frame=int(cfg.tracking.evaluations),
        cheap_evaluations_per_frame=parts.fidelity.evaluations,
        evaluations_used=int(sum(r.evaluations for r in tracking.results)),
        seconds_per_frame=tracking.search_seconds / frames,
        foreground_seconds_per_frame=tracking.foreground_seconds / frames,
        optimizer=str(cfg.optimizer.name),
        strategy=parts.strategy.name,
        dof=body.dof,
        backend=getattr(parts.evaluator, "name", "") or str(cfg.evaluator.name),  # auto's choice
        evaluator_choice=str(cfg.evaluator.name),
        vertices=body.n_vertices,
        subject=sequence.subject or "unknown",  # a recording names nobody
        body={"preset": body.subject.name, "height_mm": body.subject.height_mm, "girth": body.subject.girth},
        start=start_facts,
        plausibility=parts.plausibility.findings(),
        recoveries=[event.summary() for event in parts.recovery.events],
        action=sequence.meta.get("action"),
        cameras=[c.name for c in sequence.cameras],
        sequence=str(sequence.root),
        fps=float(sequence.fps),
        seed=int(cfg.seed),
        run_id=run_id,
        provenance={
            **provenance.facts(),
            "components": provenance.components(used_components(cfg)),
        },
        config=cast(dict, OmegaConf.to_container(cfg, resolve=True)),
        warnings=warning_messages,
    )


def used_components(cfg: DictConfig) -> dict[str, str]:
    """The registered components a run uses, by kind: its optimiser and evaluator, and the
    keypoint detector it runs (``keypoints.source=detector``)."""
    used = {"optimizer": str(cfg.optimizer.name), "evaluator": str(cfg.evaluator.name)}
    if cfg.keypoints.source == "detector":
        used["detector"] = str(cfg.keypoints.detector)
    return used


def write_outputs(
    cfg: DictConfig,
    output_dir: Path,
    parts: Components,
    sequence,
    foreground: Foreground,
    truth: np.ndarray,
    tracking: Tracking,
    summary: Summary,
) -> None:
    """Every output of a tracked run but its summary: the traces, the exports, the error plot
    (where a frame has ground truth), the overlays and, with ``video``, the videos."""
    body, results = parts.body, tracking.results
    write_traces(output_dir / TRACES, results)
    poses = read_poses(output_dir / FRAMES)
    options = instantiate(cfg.export_options)
    export_motion(
        output_dir / EXPORT_FOLDER, cfg.export, body, poses, sequence.fps, options=options, up=cfg.dataset.get("up")
    )
    errors = np.asarray(tracking.errors_mm)
    if (~np.isnan(errors)).any():
        plot_error_per_frame(
            errors,
            output_dir / ERROR_PLOT,
            f"{summary.subject} {summary.action}: {cfg.optimizer.name} "
            f"{summary.strategy}, {body.dof} DOF, {cfg.tracking.evaluations} evaluations/frame",
        )
    write_overlays(
        output_dir / OVERLAYS, sequence, foreground, parts.evaluator, body, results, truth, int(cfg.overlays)
    )
    if cfg.video:
        write_run_videos(output_dir, sequence, foreground, parts.evaluator, body, results, truth, progress=cfg.progress)


def sweep_folder() -> Path | None:
    """The folder of the Hydra multirun this job belongs to, or None."""
    if HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN:
        return Path(HydraConfig.get().sweep.dir)
    return None
