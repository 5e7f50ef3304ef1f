"""The command line, ``mmocap <subcommand> [arguments]``: the top layer of mmocap.

``mmocap [hydra overrides]`` (or ``mmocap track ...``) tracks a sequence; ``mmocap --help``
lists the subcommands and ``mmocap --version`` prints the installed version (the package
metadata's). This is the one place that turns errors into exit codes: an error the user can
fix (:class:`mmocap.errors.MmocapError`, also when Hydra wraps it, or a file-system fault: an
``OSError`` naming its path) prints one line naming the culprit and exits with status 2,
without a traceback; warnings print as one ``mmocap: warning: ...`` line each.
"""

from __future__ import annotations

import os

# The evaluators batch many small matrix products; BLAS threads only add overhead there
# (and fight with process-level parallelism), so default to one unless the user says.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import contextlib  # noqa: E402
import importlib  # noqa: E402
import sys  # noqa: E402
import warnings  # noqa: E402
from importlib.metadata import version  # noqa: E402
from pathlib import Path  # noqa: E402

import hydra  # noqa: E402
from hydra.core.hydra_config import HydraConfig  # noqa: E402
from hydra.errors import InstantiationException  # noqa: E402
from hydra.types import RunMode  # noqa: E402
from hydra.utils import instantiate  # noqa: E402
from omegaconf import DictConfig  # noqa: E402

from mmocap.config import CONFIG_NAME, CONFIG_PATH, HYDRA_VERSION_BASE  # noqa: E402
from mmocap.errors import ConfigError, DataError, MmocapError  # noqa: E402
from mmocap.io import check_writable_folder, describe_os_error  # noqa: E402
from mmocap.sweep import SweepProgress, job_overrides, unfinished_jobs  # noqa: E402


def _user_error(exc: BaseException | None) -> MmocapError | None:
    """The MmocapError behind ``exc`` (Hydra wraps errors raised while instantiating); a
    file-system fault (an OSError naming its path) becomes a DataError saying what is wrong."""
    while exc is not None:
        if isinstance(exc, MmocapError):
            return exc
        if isinstance(exc, OSError) and exc.filename is not None:
            return DataError(describe_os_error(exc))
        exc = exc.__cause__ if isinstance(exc, InstantiationException) else None
    return None


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"mmocap: warning: {message}", file=sys.stderr)


class JobRefused(BaseException):
    """A sweep job that refused to start (its message is the one line to print). A
    BaseException, so that it passes the launcher (from a joblib worker too) and Hydra's
    error report, which would print a traceback, to :func:`guarded` in the launching
    process: the line is printed once, however many jobs refuse at the same time."""


def guarded(job):
    """``job()``; a user error (also one Hydra wraps, or a refused sweep job) becomes one line
    on stderr and exit 2."""
    warnings.showwarning = _show_warning
    try:
        return job()
    except JobRefused as refused:
        print(f"mmocap: error: {refused}", file=sys.stderr)
        raise SystemExit(2) from refused  # its line says how to go on: main names no unfinished jobs
    except (MmocapError, InstantiationException, OSError) as exc:
        err = _user_error(exc)
        if err is None:
            raise
        print(f"mmocap: error: {err}", file=sys.stderr)
        raise SystemExit(2) from None


@hydra.main(config_path=CONFIG_PATH, config_name=CONFIG_NAME, version_base=HYDRA_VERSION_BASE)
def track_app(cfg: DictConfig) -> None:
    """``mmocap [track] OVERRIDES``: track the configured sequence into Hydra's output folder and
    print the run's one-line summary."""
    from mmocap.pipeline import run

    if HydraConfig.get().mode == RunMode.MULTIRUN and os.getpid() != _LAUNCHER_PID:
        _end_with_parent()
    output_dir = Path(HydraConfig.get().runtime.output_dir)
    summary = guarded(lambda: run(cfg, output_dir))
    mean = summary["mean_marker_error_mm"]  # over the frames with ground truth; None without any
    error = "no ground truth" if mean is None else f"mean marker error {mean:.1f} mm"
    print(
        f"{summary['subject']} {summary['action']}: {summary['optimizer']} {summary['strategy']} "
        f"{summary['dof']} DOF, {summary['evaluations_per_frame']} evaluations/frame"
        + (f" (+{cheap} cheaper)" if (cheap := summary.get("cheap_evaluations_per_frame")) else "")
        + ", "
        f"{summary['frames']} frames ({summary.get('frames_scored', '?')} scored): {error}, "
        f"{summary['seconds_per_frame']:.2f} s/frame ({summary['backend']} backend) -> {output_dir}"
    )


@hydra.main(config_path=CONFIG_PATH, config_name=CONFIG_NAME, version_base=HYDRA_VERSION_BASE)
def generate_app(cfg: DictConfig) -> None:
    """``mmocap generate OVERRIDES``: render the configured synthetic sequence (if not yet there)
    and print its folder, frame count and cameras."""
    sequence = guarded(lambda: instantiate(cfg.dataset).open(progress=cfg.progress))
    print(
        f"sequence ready: {sequence.root} ({sequence.n_frames} frames, "
        f"cameras {', '.join(c.name for c in sequence.cameras)})"
    )


class SweepCallback(SweepProgress):
    """:class:`mmocap.sweep.SweepProgress` whose checks before a sweep or a single run, and
    the sweep's export at its end, end the command with one line and exit 2 on an error
    (``hydra.callbacks`` in ``conf/config.yaml``)."""

    def on_multirun_start(self, config: DictConfig, **kwargs) -> None:
        _resume_hint["folder"] = str(config.hydra.sweep.dir)
        guarded(lambda: SweepProgress.on_multirun_start(self, config, **kwargs))
        _sweep_jobs[:] = job_overrides(config)

    def on_multirun_end(self, config: DictConfig, **kwargs) -> None:
        guarded(lambda: SweepProgress.on_multirun_end(self, config, **kwargs))

    def on_run_start(self, config: DictConfig, **kwargs) -> None:
        """A run folder (``hydra.run.dir``) that cannot be written, or a paper experiment from a
        checkout with uncommitted changes, ends the command with one line, before Hydra writes
        its own files there."""
        guarded(lambda: check_writable_folder(config.hydra.run.dir))
        guarded(lambda: SweepProgress.on_run_start(self, config, **kwargs))

    def on_job_start(self, config: DictConfig, **kwargs) -> None:
        """A job whose code, configs or plugins changed since the sweep started refuses to run
        (:class:`JobRefused`): the sweep ends with one line naming what changed and exit 2."""
        try:
            SweepProgress.on_job_start(self, config, **kwargs)
        except ConfigError as exc:
            raise JobRefused(str(exc)) from None


def export_humaneva(args: list[str], prog: str) -> None:
    """``mmocap export-humaneva SEQUENCE OUT``: write a synthetic sequence folder in the HumanEva-I
    layout."""
    import argparse

    from mmocap.data.humaneva.export import export
    from mmocap.data.humaneva.layout import TRIALS

    parser = argparse.ArgumentParser(
        prog=prog,
        description="Write a synthetic sequence folder in the HumanEva-I layout (S*/Calibration_Data, "
        "Image_Data, Sync_Data, Mocap_Data at 120 Hz, Background).",
    )
    parser.add_argument("sequence", help="a sequence folder (the one holding sequence.json)")
    parser.add_argument("out", help="the HumanEva-I folder to write into")
    parser.add_argument("--trial", type=int, default=1, choices=TRIALS)
    parser.add_argument(
        "--images",
        choices=("avi", "png"),
        default="avi",
        help="lossless FFV1 videos (default) or folders of numbered PNG frames",
    )
    parser.add_argument(
        "--mocap-lead",
        type=int,
        default=4,
        help="mocap frames, all markers missing, before the video starts (default 4)",
    )
    options = parser.parse_args(args)
    out = export(
        options.sequence, options.out, trial=options.trial, images=options.images, mocap_lead=options.mocap_lead
    )
    print(f"HumanEva-I layout written to {out}")


def list_components(args: list[str], prog: str) -> None:
    """``mmocap list``: print the installed optimisers and evaluators (and why any is unavailable),
    then each OpenCL device's self-check."""
    from mmocap import registry
    from mmocap.evaluators.opencl import device_checks

    print(registry.describe())
    checks = device_checks()
    if checks:
        print("OpenCL devices, self-checked against numpy with the default settings:")
        print("\n".join(f"  {line}" for line in checks))


def _hydra_app(app):
    def command(args: list[str], prog: str) -> None:
        sys.argv = [prog, *args]
        app()

    return command


def _main_of(module_name: str, function: str = "main"):
    def command(args: list[str], prog: str) -> None:
        getattr(importlib.import_module(module_name), function)(args, prog=prog)

    return command


# name -> (command(args, prog), one line of help); the commands raise MmocapError for bad input.
SUBCOMMANDS = {
    "track": (_hydra_app(track_app), "track a sequence (the default): `mmocap [track] optimizer=pso ...`"),
    "generate": (_hydra_app(generate_app), "render the configured synthetic sequence only [Hydra overrides]"),
    "list": (
        list_components,
        "the installed optimisers and evaluators, why any is unavailable, and each OpenCL device's self-check",
    ),
    "export-humaneva": (export_humaneva, "write a synthetic sequence folder in the HumanEva-I layout"),
    "check-recording": (
        _main_of("mmocap.data.recording.commands", "check_main"),
        "check a recording folder (calibration, videos, sync, first frame) before tracking it",
    ),
    "to-recording": (
        _main_of("mmocap.data.recording.commands", "convert_main"),
        "write a sequence folder as a user's recording (OpenCV YAML calibration, MP4 videos)",
    ),
    "pose2sim-demo": (
        _main_of("mmocap.data.recording.commands", "pose2sim_demo_main"),
        "get Pose2Sim's real 4-camera demo recording (from its wheel on the package index)",
    ),
    "export": (_main_of("mmocap.writers.export"), "a finished run's motion as TRC, C3D, BVH and CSV files"),
    "collect": (_main_of("mmocap.report.collect"), "write runs.csv and frames.csv of a sweep folder"),
    "store": (
        _main_of("mmocap.analysis.migration"),
        "keep a results store: `mmocap store migrate FOLDER` renames its records for this mmocap's key rules",
    ),
    "ioh": (_main_of("mmocap.report.ioh"), "the runs' per-frame convergence traces for IOHanalyzer"),
    "summaries": (_main_of("mmocap.report.summaries"), "table of the run summaries below a folder"),
    "stats": (_main_of("mmocap.report.stats"), "Friedman test and Holm's comparisons on a table of results"),
    "paper": (_main_of("mmocap.report.paper"), "make a paper table or figure from a sweep's runs.csv"),
    "held-out": (
        _main_of("mmocap.report.held_out"),
        "a finished run against a camera it was not tracked with: silhouette IoU, joint distance",
    ),
    "keypoint-offsets": (
        _main_of("mmocap.report.keypoint_offsets"),
        "where MediaPipe's landmarks lie relative to the model's joints, measured on synthetic data",
    ),
    "results-page": (_main_of("mmocap.report.results_page"), "put Markdown tables on a stamped docs/results page"),
    "bench": (_main_of("mmocap.bench.cli"), "evaluator benchmark: Cano Tables 1 and 2 and Fig. 3 here"),
    "lossy": (
        _main_of("mmocap.report.lossy"),
        "recordings of synthetic sequences at several crf, and the table of `make lossy`",
    ),
    "foreground-quality": (
        _main_of("mmocap.report.foreground_quality"),
        "precision, recall and IoU of each background method per camera",
    ),
}


def usage() -> str:
    """The text of ``mmocap --help``: the usage line and one line per subcommand."""
    width = max(map(len, SUBCOMMANDS))
    lines = [
        "usage: mmocap [SUBCOMMAND] [ARGUMENTS]",
        "",
        "Markerless multi-camera motion capture. Without a subcommand the arguments are Hydra",
        "overrides of a tracking run; `mmocap track --help` shows its config, `--hydra-help` Hydra's.",
        "",
        "subcommands:",
    ]
    lines += [f"  {name:<{width}}  {text}" for name, (_, text) in SUBCOMMANDS.items()]
    lines += ["", "`mmocap SUBCOMMAND --help` describes one; `mmocap --version` prints the version."]
    return "\n".join(lines)


def _end_with_parent() -> None:
    """Ask Linux to SIGTERM this worker process when the process that started it ends, even
    by SIGKILL, so that no worker of a killed sweep runs on (elsewhere: nothing happens)."""
    import ctypes
    import signal

    parent = os.getppid()
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # 1 = PR_SET_PDEATHSIG
    except (AttributeError, OSError):
        return
    if os.getppid() != parent:  # the parent ended before the request was in place
        os._exit(128 + signal.SIGTERM)


# the process that ran ``main``: a sweep's jobs run in it (n_jobs=1) or in its workers
_LAUNCHER_PID = os.getpid()
# the sweep folder of this command, once known: the interruption message tells how to resume it
_resume_hint: dict[str, str] = {}
# each job's overrides, once the sweep has started: a sweep that ends in an error names those left
_sweep_jobs: list[list[str]] = []
# the most unfinished jobs that line names one by one
NAMED_JOBS = 10
# seconds the worker processes get to end after SIGTERM before they are killed
WORKER_GRACE_SECONDS = 3.0


def _descendants(pid: int) -> list[int]:
    """The process ids of every descendant of ``pid`` (Linux ``/proc``; none elsewhere)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue  # the process ended meanwhile
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found, queue = [], [pid]
    while queue:
        for child in children.get(queue.pop(), []):
            found.append(child)
            queue.append(child)
    return found


def _stop_workers() -> None:
    """SIGTERM to every descendant process (a sweep's workers and their resource trackers),
    then SIGKILL to those still there after :data:`WORKER_GRACE_SECONDS`."""
    import signal
    import time

    workers = _descendants(os.getpid())
    for pid in workers:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + WORKER_GRACE_SECONDS
    while workers and time.monotonic() < deadline:
        workers = [pid for pid in workers if Path(f"/proc/{pid}").exists() and not _is_zombie(pid)]
        time.sleep(0.05)
    for pid in workers:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


def _is_zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except (OSError, IndexError):
        return True


def _interrupted(signum, frame) -> None:
    """On SIGTERM or SIGINT: stop the workers, say how to resume, exit 128 + signal number.
    Every output is written atomically, so what an interrupted write leaves is a temporary
    file that a rerun removes or ignores; finished runs keep their records."""
    import signal

    _stop_workers()
    folder = _resume_hint.get("folder")
    where = (
        (
            f"finished runs are kept in {folder}/records; run the same command with "
            f"hydra.sweep.dir={folder} to run only the rest"
        )
        if folder
        else "the run did not finish and wrote no record; run the same command again"
    )
    print(f"mmocap: interrupted by {signal.Signals(signum).name}; {where}", file=sys.stderr, flush=True)
    os._exit(128 + signum)


def _report_unfinished_jobs() -> None:
    """After a sweep that ended in an error (a job failed, or its worker died and the launcher
    gave up on it): one line naming the jobs that did not finish and how to run only them."""
    folder = _resume_hint.get("folder")
    left = unfinished_jobs(Path(folder), _sweep_jobs) if folder and _sweep_jobs else []
    if not left:
        return
    named = ", ".join(left[:NAMED_JOBS]) + (f" and {len(left) - NAMED_JOBS} more" if len(left) > NAMED_JOBS else "")
    print(
        f"mmocap: error: {len(left)} of {len(_sweep_jobs)} sweep jobs did not finish: {named}; finished runs "
        f"are kept in {folder}/records; run the same command with hydra.sweep.dir={folder} to run only the rest",
        file=sys.stderr,
        flush=True,
    )


@contextlib.contextmanager
def _interruptible():
    """SIGTERM and SIGINT handled by :func:`_interrupted` for the block (main thread only)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, _interrupted) for sig in (signal.SIGTERM, signal.SIGINT)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def main(argv: list[str] | None = None) -> None:
    """The ``mmocap`` command: run the subcommand named first in ``argv`` (default: the process's
    arguments), ``track`` if none is named; a user error prints one line and exits 2."""
    args = sys.argv[1:] if argv is None else list(argv)
    if args and args[0] in ("-h", "--help"):
        print(usage())
        return
    if args and args[0] == "--version":
        print(f"mmocap {version('mmocap')}")
        return
    name = args.pop(0) if args and args[0] in SUBCOMMANDS else "track"
    command, _ = SUBCOMMANDS[name]
    _sweep_jobs.clear()  # a sweep of an earlier call in this process (the tests run several)
    with _interruptible():
        try:
            guarded(lambda: command(args, f"mmocap {name}"))
        except SystemExit as end:
            if end.code and not isinstance(end.__cause__, JobRefused):
                _report_unfinished_jobs()
            raise


if __name__ == "__main__":
    main()
