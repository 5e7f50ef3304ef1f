"""The main job: build every stage from the config, track a sequence, write the results.

Outputs in ``output_dir``: ``frames.csv`` (one row per frame, written as it goes),
``traces.csv`` (each frame's convergence: :mod:`mmocap.report.ioh`), ``error_per_frame.png``,
``overlays/*.png`` and ``summary.json``; and the run's record in
the results store (:mod:`mmocap.analysis.results`). A run whose record is already in the
store, or in one of ``results.reuse``, is not run again.

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
from pathlib import Path

import cv2
import numpy as np
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from tqdm.auto import tqdm

from mmocap import provenance
from mmocap.analysis.figures import overlay, plot_error_per_frame
from mmocap.analysis.results import ResultsStore, make_record, run_key, store_folder
from mmocap.errors import ConfigError, DataError, MmocapWarning
from mmocap.evaluators.timed import TimedEvaluator
from mmocap.io import LockBusy, exclusive, locked, write_image, write_json_atomic, writing
from mmocap.preflight import check_config
from mmocap.report.export import EXPORT_FOLDER, export_motion, exported_files, read_poses
from mmocap.report.ioh import TRACES, write_traces
from mmocap.report.videos import run_video_files, write_run_videos
from mmocap.stages.evaluation import FrameLog, marker_error
from mmocap.stages.foreground import Foreground
from mmocap.stages.tracking import track

log = logging.getLogger(__name__)

#: the lock file a run holds in its folder
RUN_LOCK = ".run.lock"
#: the files a run writes into its folder (besides ``overlays/*.png``)
RUN_OUTPUTS = ("frames.csv", "frames.csv.partial", TRACES, "error_per_frame.png", "summary.json")


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
        except LockBusy as busy:
            raise DataError(f"run folder {output_dir} is in use by another run ({busy.holder}): wait for it "
                            "to finish, use another hydra.run.dir, or set run_dir_busy=wait to wait for it") from None
        yield


def clear_outputs(output_dir: Path) -> None:
    """Remove what an earlier run that left no record wrote into ``output_dir`` (its
    :data:`RUN_OUTPUTS`, overlays and temporary files), so that no file of another run lies
    beside this run's."""
    overlays = output_dir / "overlays"
    with writing(output_dir):
        for path in [*(output_dir / name for name in RUN_OUTPUTS), *output_dir.glob(".*.tmp"),
                     *overlays.glob("frame_*.png"), *overlays.glob(".*.tmp"),
                     *exported_files(output_dir / EXPORT_FOLDER), *run_video_files(output_dir)]:
            path.unlink(missing_ok=True)


def _run(cfg: DictConfig, output_dir: Path, warning_messages: list[str]) -> dict:
    output_dir.mkdir(parents=True, exist_ok=True)
    store = ResultsStore(store_folder(cfg, sweep_folder() or output_dir))
    run_id = run_key(cfg)
    done = store.get(run_id) or store.adopt(run_id, cfg.results.reuse)
    if done is not None:
        log.info("run %s already finished (record %s): skipped; delete the record to run it again",
                 run_id, store.path(run_id))
        return done["summary"]
    clear_outputs(output_dir)
    store.clear_unfinished(run_id)
    started = provenance.now()

    # Components first: a bad value fails before any data is rendered or read.
    optimizer = instantiate(cfg.optimizer)
    strategy = instantiate(cfg.strategy)
    evaluator = TimedEvaluator(instantiate(cfg.evaluator))
    body = instantiate(cfg.body)
    coverage = instantiate(cfg.coverage)
    auto_start = instantiate(cfg.start)
    recovery = instantiate(cfg.recovery)
    fidelity = instantiate(cfg.fidelity, evaluator=lambda: instantiate(cfg.evaluator),
                           optimizer=lambda **settings: instantiate(cfg.optimizer, **settings))
    missing_markers = str(cfg.evaluation.missing_markers)
    strategy.check(body, optimizer, int(cfg.tracking.evaluations))
    fidelity.check(strategy)
    dataset = instantiate(cfg.dataset)
    with exclusive(getattr(dataset, "path", None)):  # parallel jobs render a sequence once
        sequence = dataset.open(progress=cfg.progress)
    if sequence.subject is not None and body.subject.name != sequence.subject:
        raise ConfigError(f"body.subject is {body.subject.name} but the sequence shows {sequence.subject}")
    n_frames = sequence.n_frames if cfg.tracking.frames is None else int(cfg.tracking.frames)
    truth = sequence.ground_truth(n_frames, missing_markers)  # NaN where a frame has none
    foreground = Foreground(sequence, instantiate(cfg.background), cache_dir=cfg.foreground_cache)

    frame_log = FrameLog(output_dir / "frames.csv")
    errors, frame_rows = [], []
    bar = tqdm(total=n_frames, desc=f"track {cfg.optimizer.name}", unit="frame", disable=not cfg.progress)

    def on_frame(result):
        err = float(marker_error(body.markers(result.pose[None]), truth[result.frame][None])[0])
        errors.append(err)
        frame_rows.append({"frame": int(result.frame), "marker_error_mm": err, "fitness": float(result.fitness),
                           "evaluations": int(result.evaluations), "seconds": float(result.seconds),
                           "foreground_seconds": float(result.foreground_seconds)})
        frame_log.write(result.frame, err, result.fitness, result.evaluations, result.seconds, result.pose)
        scored_so_far = [e for e in errors if not np.isnan(e)]
        bar.set_postfix(error_mm=f"{err:.1f}", mean_mm=f"{np.mean(scored_so_far):.1f}" if scored_so_far else "-")
        bar.update()

    rng = np.random.default_rng(int(cfg.seed))
    x0, start_facts = sequence.x0, {"method": "given"}
    start_pose = body.rest_pose() if x0 is None else x0
    evaluator.warm_up(body, foreground, start_pose)
    fidelity.warm_up(body, foreground.cameras, foreground.masks(0), start_pose)
    if auto_start.wanted(has_x0=x0 is not None):
        found = auto_start.find(body, foreground.cameras, foreground.masks(0), evaluator, optimizer, strategy, rng,
                                fit_height=cfg.body.get("height_mm") is None, fit_girth=cfg.body.get("girth") is None)
        body, x0, start_facts = found.body, found.pose, found.summary()
        evaluator.seconds = 0.0  # the tracking's evaluation time from here on; the start's is in start_facts
        log.info("automatic start: %.1f s, %d evaluations; body %.0f mm tall, girth %.2f", found.seconds,
                 found.evaluations, body.subject.height_mm, body.subject.girth)
    try:
        results = track(sequence, body, foreground, evaluator, optimizer, strategy,
                        evaluations=int(cfg.tracking.evaluations), seed=int(cfg.seed),
                        frames=cfg.tracking.frames, on_frame=on_frame, coverage=coverage, x0=x0, rng=rng,
                        recovery=recovery, fidelity=fidelity)
    except BaseException:
        frame_log.close(complete=False)  # the frames tracked stay in frames.csv.partial
        raise
    finally:
        bar.close()
    frame_log.close()
    write_traces(output_dir / TRACES, results)
    search_seconds = sum(r.seconds for r in results)
    foreground_seconds = sum(r.foreground_seconds for r in results)
    export_motion(output_dir / EXPORT_FOLDER, cfg.export, body, read_poses(output_dir / "frames.csv"), sequence.fps)

    errors = np.asarray(errors)  # type: ignore[assignment]  # the list as an array from here on
    scored = errors[~np.isnan(errors)]  # frames with ground truth; the statistics are over them, null if none
    summary = {
        "mean_marker_error_mm": float(np.mean(scored)) if scored.size else None,
        "median_marker_error_mm": float(np.median(scored)) if scored.size else None,
        "max_marker_error_mm": float(np.max(scored)) if scored.size else None,
        "frames": len(results),
        "frames_scored": int(scored.size),
        "evaluations_per_frame": int(cfg.tracking.evaluations),  # the exact search's
        "cheap_evaluations_per_frame": fidelity.evaluations,  # the cheaper fitness levels' (mmocap.stages.fidelity)
        "evaluations_used": int(sum(r.evaluations for r in results)),
        "seconds_per_frame": search_seconds / len(results),  # the search alone
        "foreground_seconds_per_frame": foreground_seconds / len(results),
        "optimizer": str(cfg.optimizer.name),
        "strategy": strategy.name,
        "dof": body.dof,
        "backend": getattr(evaluator, "name", "") or str(cfg.evaluator.name),  # auto's choice
        "evaluator_choice": str(cfg.evaluator.name),
        "vertices": body.n_vertices,
        "subject": sequence.subject or "unknown",  # a recording names nobody
        "body": {"preset": body.subject.name, "height_mm": body.subject.height_mm, "girth": body.subject.girth},
        "start": start_facts,
        "recoveries": [event.summary() for event in recovery.events],
        "action": sequence.meta.get("action"),
        "cameras": [c.name for c in sequence.cameras],
        "sequence": str(sequence.root),
        "fps": float(sequence.fps),
        "seed": int(cfg.seed),
        "run_id": run_id,
        "provenance": {**provenance.facts(), "components": provenance.components(
            {"optimizer": str(cfg.optimizer.name), "evaluator": str(cfg.evaluator.name)})},
        "config": OmegaConf.to_container(cfg, resolve=True),
        "warnings": warning_messages,
    }
    if scored.size:
        plot_error_per_frame(errors, output_dir / "error_per_frame.png",  # type: ignore[arg-type]  # the array above
                             f"{summary['subject']} {sequence.meta.get('action')}: {cfg.optimizer.name} "
                             f"{strategy.name}, {body.dof} DOF, {cfg.tracking.evaluations} evaluations/frame")
    write_overlays(output_dir / "overlays", sequence, foreground, evaluator, body, results, truth,
                   int(cfg.overlays))
    if cfg.video:
        write_run_videos(output_dir, sequence, foreground, evaluator, body, results, truth, progress=cfg.progress)
    write_json_atomic(output_dir / "summary.json", summary)  # the last output: the run is complete
    evaluator.close()
    fidelity.close()
    path = store.put(make_record(cfg, summary, frame_rows, search_seconds, evaluator.seconds, foreground_seconds,
                                 started, output_dir))
    log.info("run %s recorded in %s", run_id, path)
    return summary


def sweep_folder() -> Path | None:
    """The folder of the Hydra multirun this job belongs to, or None."""
    if HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN:
        return Path(HydraConfig.get().sweep.dir)
    return None


def write_overlays(folder: Path, sequence, foreground, evaluator, body, results, truth, count: int) -> None:
    """The tracked model over undistorted camera images for ``count`` evenly spaced frames,
    one PNG each, written atomically (a WriteError naming it if it cannot be)."""
    if count == 0:
        return
    cameras = foreground.cameras
    for k in np.unique(np.linspace(0, len(results) - 1, count).round().astype(int)):
        result = results[k]
        evaluator.setup(body, cameras, foreground.masks(result.frame))
        joints = body.joint_positions(result.pose[None])[0]
        tiles = []
        for c, (cam, image) in enumerate(zip(sequence.cameras, sequence.images(result.frame))):
            mx, my = cam.undistort_maps()
            ideal_image = cv2.remap(image, mx, my, cv2.INTER_LINEAR)
            tile = overlay(ideal_image, cameras[c], evaluator.render(result.pose, c), joints, truth[result.frame])
            cv2.putText(tile, f"{cam.name} frame {result.frame}", (8, 20), cv2.FONT_HERSHEY_SIMPLEX,
                        0.55, (255, 255, 255), 1, cv2.LINE_AA)
            tiles.append(tile)
        if not tiles:
            raise DataError("no camera images to draw overlays on")
        write_image(folder / f"frame_{result.frame:06d}.png", _grid(tiles))


def _grid(tiles: list[np.ndarray]) -> np.ndarray:
    """Tiles, resized to the first one's size, in a grid of two columns."""
    h, w = tiles[0].shape[:2]
    tiles = [t if t.shape[:2] == (h, w) else cv2.resize(t, (w, h)) for t in tiles]
    if len(tiles) % 2:
        tiles = tiles + [np.zeros_like(tiles[0])]
    rows = [np.hstack(tiles[i:i + 2]) for i in range(0, len(tiles), 2)]
    return np.vstack(rows)
