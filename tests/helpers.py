"""What the tests share besides fixtures: the tiny configurations, the ways to run the
command line, and the checks of what a user sees. (``conftest.py`` files hold fixtures only.)

Running the command line:

- :func:`mmocap`: ``python -m mmocap ARGS`` in a subprocess, as a user runs it (the one
  subprocess runner; for what only a fresh process shows: start-up, imports, signals,
  launchers, the environment);
- :func:`mmocap_in_process`: the same command through :func:`mmocap.cli.main` in this
  process, with both streams and the exit status captured the same way (a second or more
  faster per run; for a test of what the command says or writes);
- :func:`run_cli`: :func:`mmocap.cli.main` in this process, leaving the output to the test's
  ``capsys``; returns the exit status.
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import traceback
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
from hydra.experimental.callback import Callback
from hypothesis import strategies as st
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PathCollection
from matplotlib.text import Text
from PIL import Image

from mmocap import config as mmocap_config
from mmocap import provenance
from mmocap.analysis.results import make_record
from mmocap.data.calibration import read_calibration, write_opencv_yaml
from mmocap.data.humaneva.dataset import HumanEvaDataset
from mmocap.data.humaneva.layout import TOOLBOX_FIRST_FRAME
from mmocap.errors import DataError, MmocapWarning

#: the tiny synthetic sequence of the session fixture ``tiny_sequence`` (tests/conftest.py):
#: 4 frames, 3 cameras (two colour, one greyscale), 320x240
TINY = dict(
    subject="S1",
    action="walking",
    frames=4,
    cameras=("C1", "C2", "BW1"),
    width=320,
    height=240,
    background_frames=3,
    seed=5,
)

#: the tiny sequence that the bad-input corpus breaks copies of (``tiny_original``,
#: tests/bad_input/conftest.py) and the fault tests sweep over: 2 frames, 2 cameras (one
#: colour, one greyscale), 160x120
TINY_BAD_INPUT = dict(
    subject="S1", action="walking", frames=2, cameras=("C1", "BW1"), width=160, height=120, background_frames=3, seed=3
)


#: the automatic start's settings for a quick test run: a few hundred evaluations
QUICK_START = [
    "start.headings=4",
    "start.candidates=1",
    "start.refined=1",
    "start.evaluations=80",
    "start.limb_evaluations=40",
    "start.limb_samples=20",
    "start.limb_restarts=1",
    "start.rounds=1",
    "start.girth_steps=[0.1]",
    "start.height_steps_mm=[]",
    "start.shape_evaluations=40",
    "start.shape_passes=1",
    "start.hull_height_offsets_mm=[0]",
]


def overrides(root, **extra) -> list[str]:
    """Command-line overrides that select the :data:`TINY` sequence under ``root`` and track
    2 frames of it at 300 evaluations; ``extra`` adds or replaces overrides."""
    args = {
        "dataset.root": str(root),
        "dataset.frames": TINY["frames"],
        "dataset.cameras": "[" + ",".join(TINY["cameras"]) + "]",
        "dataset.all_cameras": "[" + ",".join(TINY["cameras"]) + "]",
        "dataset.width": TINY["width"],
        "dataset.height": TINY["height"],
        "dataset.background_frames": TINY["background_frames"],
        "dataset.seed": TINY["seed"],
        "progress": "false",
        "overlays": 1,
        "tracking.frames": 2,
        "tracking.evaluations": 300,
    }
    args.update(extra)
    return [f"{k}={v}" for k, v in args.items()]


def track_args(root: Path, out: Path) -> list[str]:
    """Overrides of a quick tracking run of the :data:`TINY_BAD_INPUT` sequence folder
    ``root`` into ``out``."""
    return [
        "dataset=folder",
        f"dataset.root={root}",
        f"dataset.subject={TINY_BAD_INPUT['subject']}",
        "evaluator=numpy",
        "body.vertices=1000",
        "tracking.evaluations=60",
        "overlays=1",
        "progress=false",
        "foreground_cache=null",
        f"hydra.run.dir={out}",
    ]


def box_in_the_scene(sequence: Path) -> None:
    """A black box over a twelfth of every image of the sequence folder ``sequence`` that its
    background frames lack, as if something had been put into the scene after the empty scene
    was filmed: a foreground the body model cannot explain."""
    for path in sorted((sequence / "images").glob("*/*.png")):
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        height, width = image.shape[:2]
        image[height // 8 : height // 8 + height // 3, width // 16 : width // 16 + width // 4] = 0
        assert cv2.imwrite(str(path), image)


@dataclass
class Outcome:
    """What the user saw: the exit status and both streams."""

    args: list[str]
    code: int
    stdout: str
    stderr: str

    @property
    def returncode(self) -> int:
        """The exit status, by the name :class:`subprocess.CompletedProcess` gives it."""
        return self.code

    def __str__(self) -> str:
        return (
            f"mmocap {' '.join(self.args)}\nexit status {self.code}\n"
            f"--- stderr ---\n{self.stderr[-3000:]}\n--- stdout ---\n{self.stdout[-1500:]}"
        )


def mmocap(*args, cwd: Path | None = None, timeout: float = 600, env: dict | None = None) -> Outcome:
    """``python -m mmocap ARGS`` in a subprocess, as a user runs it; ``env`` adds variables."""
    args = [str(a) for a in args]
    environment = {**os.environ, "HYDRA_FULL_ERROR": "0", **(env or {})}
    done = subprocess.run(
        [sys.executable, "-m", "mmocap", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=environment,
    )
    return Outcome(args, done.returncode, done.stdout, done.stderr)


@contextlib.contextmanager
def _environment(env: dict):
    saved = {name: os.environ.get(name) for name in env}
    os.environ.update(env)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def mmocap_in_process(*args, cwd: Path | None = None, timeout: float = 600, env: dict | None = None) -> Outcome:
    """``mmocap ARGS`` through :func:`mmocap.cli.main` in this process, seen as
    :func:`mmocap` sees it: both streams captured, the exit status of ``SystemExit`` (0 when
    it returns), and an uncaught exception as its traceback on stderr with status 1.
    ``timeout`` is not enforced (it is there so that both runners take the same arguments);
    every warning shows, as in a fresh process."""
    from mmocap.cli import main

    args = [str(a) for a in args]
    out, err = io.StringIO(), io.StringIO()
    with (
        _environment({"HYDRA_FULL_ERROR": "0", **(env or {})}),
        contextlib.chdir(cwd or os.getcwd()),
        warnings.catch_warnings(),
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
    ):
        warnings.simplefilter("default")
        try:
            main(args)
            code = 0
        except SystemExit as exc:
            code = 0 if exc.code is None else exc.code if isinstance(exc.code, int) else 1
        except Exception:  # noqa: BLE001 - shown as a fresh process shows it
            traceback.print_exc(file=err)
            code = 1
    return Outcome(args, code, out.getvalue(), err.getvalue())


def run_cli(*args) -> int:
    """``mmocap ARGS`` in this process; returns its exit status (0 when it returns)."""
    from mmocap.cli import main

    try:
        main([str(a) for a in args])
    except SystemExit as exc:
        return 0 if exc.code is None else exc.code
    return 0


def fault_sweep_command(sequence: Path, folder: Path, jobs: int, *launcher: str) -> list[str]:
    """The command line of a sweep of ``jobs`` runs (seeds 0..jobs-1) of two frames each (about
    a second a frame) on the synthetic ``sequence`` into ``folder``, with ``launcher``'s
    overrides: what the fault tests interrupt."""
    return [
        sys.executable,
        "-m",
        "mmocap",
        "-m",
        f"seed={','.join(map(str, range(jobs)))}",
        "dataset=folder",
        f"dataset.root={sequence}",
        "evaluator=numpy",
        "body.vertices=1000",
        "tracking.evaluations=3000",
        "overlays=0",
        "progress=false",
        "foreground_cache=null",
        f"hydra.sweep.dir={folder}",
        *launcher,
    ]


def session_processes(session: int) -> list[int]:
    """Live (not zombie) processes of the session ``session`` (Linux ``/proc``): what is left of
    a command started with ``start_new_session=True``, whose pid is its session's id."""
    alive = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == session and fields[0] != "Z":
            alive.append(int(stat.parent.name))
    return alive


def processes_left(session: int, wait: float = 10.0) -> list[int]:
    """The live processes of the session ``session`` (:func:`session_processes`) after waiting
    up to ``wait`` seconds for them to end by themselves."""
    import time

    deadline = time.monotonic() + wait
    while session_processes(session) and time.monotonic() < deadline:
        time.sleep(0.1)
    return session_processes(session)


def end_session(session: int, grace: float = 3.0) -> None:
    """SIGTERM to every process of the session ``session``, then SIGKILL to those still there
    after ``grace`` seconds; returns when none is left."""
    import signal
    import time

    for sig, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, grace)):
        for pid in session_processes(session):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, sig)
        deadline = time.monotonic() + wait
        while session_processes(session) and time.monotonic() < deadline:
            time.sleep(0.1)


#: the repository's root: ``PYTHONPATH`` of a subprocess that imports ``tests`` (a Hydra callback of this module)
REPOSITORY = Path(__file__).resolve().parents[1]


class EditAfterSweepStart(Callback):
    """A Hydra callback that appends a comment to the file ``path`` once a sweep has started,
    after mmocap's own callback has pinned the sweep: a config file edited while the sweep
    runs. Added by the overrides :func:`edit_after_sweep_start` gives."""

    def __init__(self, path: str) -> None:
        self.path = Path(path)

    def on_multirun_start(self, config, **kwargs) -> None:
        with self.path.open("a") as file:
            file.write("# edited after the sweep started\n")


def edit_after_sweep_start(path: Path) -> list[str]:
    """Overrides that add :class:`EditAfterSweepStart` of ``path`` to a sweep (a subprocess
    needs ``PYTHONPATH`` = :data:`REPOSITORY`)."""
    return [f"+hydra.callbacks.edit._target_={__name__}.EditAfterSweepStart", f"+hydra.callbacks.edit.path={path}"]


def assert_clean_error(outcome: Outcome, *culprits: str) -> str:
    """Exit status 2, no traceback, and one ``mmocap: error:`` line naming every culprit
    (case-insensitive); returns that line."""
    assert "Traceback" not in outcome.stderr, f"a traceback:\n{outcome}"
    assert outcome.code == 2, f"exit status {outcome.code}, expected 2:\n{outcome}"
    lines = [line for line in outcome.stderr.splitlines() if line.startswith("mmocap: error:")]
    assert len(lines) == 1, f"expected one 'mmocap: error:' line:\n{outcome}"
    for culprit in culprits:
        assert culprit.lower() in lines[0].lower(), f"the error does not name {culprit!r}:\n{outcome}"
    return lines[0]


def assert_warned(outcome: Outcome, summary: dict, *words: str) -> str:
    """Exit status 0, no traceback, a ``mmocap: warning:`` line naming every word, and the
    same warning in ``summary["warnings"]``; returns the line."""
    assert "Traceback" not in outcome.stderr, f"a traceback:\n{outcome}"
    assert outcome.code == 0, f"exit status {outcome.code}, expected 0:\n{outcome}"
    lines = [
        line
        for line in outcome.stderr.splitlines()
        if line.startswith("mmocap: warning:") and all(w.lower() in line.lower() for w in words)
    ]
    assert lines, f"no warning naming {words}:\n{outcome}"
    recorded = [w for w in summary.get("warnings", []) if all(x.lower() in w.lower() for x in words)]
    assert recorded, f"summary.json does not record the warning {words}: {summary.get('warnings')}"
    return lines[0]


# -- files cut short or damaged: the property tests of every reader -------------------------------


@dataclass(frozen=True)
class Damage:
    """A valid file's bytes damaged as a copy, a download or a disk damages them: ``cut`` at
    ``offset`` (the bytes before it kept) or one byte at ``offset`` replaced by ``byte``."""

    kind: str
    offset: int
    byte: int = 0

    def apply(self, data: bytes) -> bytes:
        """``data`` damaged."""
        if self.kind == "cut":
            return data[: self.offset]
        return data[: self.offset] + bytes([self.byte]) + data[self.offset + 1 :]

    def whole_lines(self, data: bytes) -> int:
        """How many whole lines (each with its line end) a cut of ``data`` keeps."""
        return data[: self.offset].count(b"\n")


def damages(data: bytes, kinds: tuple[str, ...] = ("cut", "byte")) -> st.SearchStrategy[Damage]:
    """The :class:`Damage` of ``data``'s bytes that Hypothesis draws: a cut anywhere before its
    end (half of them in its last 64 bytes, where a cut can leave a file that parses), or a
    byte replaced by another."""
    offsets = st.integers(0, len(data) - 1) | st.integers(max(0, len(data) - 64), len(data) - 1)
    cuts = st.builds(Damage, st.just("cut"), offsets)
    changes = st.builds(Damage, st.just("byte"), st.integers(0, len(data) - 1), st.integers(0, 255)).filter(
        lambda d: d.byte != data[d.offset]
    )
    return st.one_of(*([cuts] if "cut" in kinds else []), *([changes] if "byte" in kinds else []))


def read_or_refused(read, name: str, *args, **kwargs):
    """``(read(*args, **kwargs), the MmocapWarning messages it gave)``, or None when it refuses
    with a one-line DataError naming ``name``. Any other exception fails the test."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = read(*args, **kwargs)
        except DataError as exc:
            message = str(exc)
            assert "\n" not in message, f"a message of several lines: {message!r}"
            assert name in message, f"the message does not name {name}: {message!r}"
            return None
    return result, [str(w.message) for w in caught if issubclass(w.category, MmocapWarning)]


def read_damaged(read, path: Path, damage: Damage, whole: bytes):
    """:func:`read_or_refused` of ``read(damaged)``: ``damaged`` is the copy, written beside
    ``path`` as ``damaged-<name>``, of the file whose valid bytes are ``whole``, damaged by
    ``damage``."""
    damaged = path.with_name("damaged-" + path.name)
    damaged.write_bytes(damage.apply(whole))
    return read_or_refused(read, str(damaged), damaged)


# -- figures: what a user sees of a saved plot ---------------------------------------------------

#: tolerance (pixels) of the containment checks, for anti-aliased edges
SLACK_PX = 1.0


def inside(box, outer) -> bool:
    """``box`` lies inside ``outer`` (display boxes), to :data:`SLACK_PX`."""
    return (
        box.x0 >= outer.x0 - SLACK_PX
        and box.y0 >= outer.y0 - SLACK_PX
        and box.x1 <= outer.x1 + SLACK_PX
        and box.y1 <= outer.y1 + SLACK_PX
    )


def texts_of(fig) -> list[Text]:
    """The texts that a figure draws: its own (suptitle), its axes' titles, labels and
    annotations, and its legends' entries."""
    texts = list(fig.texts)
    for ax in fig.axes:
        texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label, *ax.texts]
        if hasattr(ax, "zaxis"):
            texts.append(ax.zaxis.label)
    for legend in legends_of(fig):
        texts += legend.get_texts()
    return [t for t in texts if t.get_visible() and t.get_text()]


def legends_of(fig) -> list:
    """The legends a figure draws: its own and its axes'."""
    return list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]


def data_points_px(ax) -> np.ndarray:
    """(N, 2) display coordinates of an axes' data: its lines (densely along each segment),
    scatter points, bands and boxes; those outside the axes (not drawn) left out."""
    points = []
    for line in ax.lines:
        xy = line.get_transform().transform(line.get_xydata())
        steps = np.linspace(0, 1, 16)[:, None, None]
        points.append((xy[:-1] + steps * (xy[1:] - xy[:-1])).reshape(-1, 2) if len(xy) > 1 else xy)
    for collection in ax.collections:
        if isinstance(collection, PathCollection):
            points.append(collection.get_offset_transform().transform(collection.get_offsets()))
        else:
            points += [collection.get_transform().transform(p.vertices) for p in collection.get_paths()]
    for patch in ax.patches:
        points.append(patch.get_transform().transform(patch.get_path().vertices))
    points = np.concatenate([p for p in points if len(p)]) if points else np.empty((0, 2))
    points = points[np.isfinite(points).all(axis=1)]
    box = ax.bbox
    return points[
        (points[:, 0] >= box.x0) & (points[:, 0] <= box.x1) & (points[:, 1] >= box.y0) & (points[:, 1] <= box.y1)
    ]


def assert_fits(fig, path):
    """The saved image is the figure's canvas; every text, legend and axes (with its tick
    labels) lies inside it; no legend covers a data point of a 2-D axes."""
    canvas = FigureCanvasAgg(fig)  # a closed figure keeps no canvas that draws
    canvas.draw()
    renderer = canvas.get_renderer()
    canvas = fig.bbox
    with Image.open(path) as image:
        assert np.abs(np.subtract(image.size, canvas.size)).max() < 1, "the image is not the canvas"
    for text in texts_of(fig):
        assert inside(text.get_window_extent(renderer), canvas), f"text {text.get_text()!r} is cut off"
    for legend in legends_of(fig):
        assert inside(legend.get_window_extent(renderer), canvas), "a legend is cut off"
    for ax in fig.axes:
        assert inside(ax.get_tightbbox(renderer), canvas), f"axes {ax.get_title()!r} is cut off"
    for legend in legends_of(fig):
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            if hasattr(ax, "zaxis"):
                continue
            points = data_points_px(ax)
            covered = (
                (points[:, 0] > box.x0) & (points[:, 0] < box.x1) & (points[:, 1] > box.y0) & (points[:, 1] < box.y1)
            )
            assert not covered.any(), f"the legend covers {covered.sum()} data points of {ax.get_title()!r}"


def assert_whole_frame_ticks(ax):
    """The x ticks an axes shows are whole frame numbers."""
    low, high = sorted(ax.get_xlim())
    ticks = [t for t in ax.get_xticks() if low <= t <= high]
    assert ticks, ticks
    assert all(float(t).is_integer() for t in ticks), ticks


# -- results store: records as the pipeline makes them ----------------------------------------------


def compose_config(*overrides, hydra=False):
    """Mmocap's config composed with ``overrides`` (and Hydra's own, with ``hydra``)."""
    return mmocap_config.compose(list(overrides), return_hydra_config=hydra)


def summary_of(cfg, errors):
    """A summary as the pipeline writes it, for a run of ``cfg`` with these frame errors."""
    return {
        "mean_marker_error_mm": float(np.mean(errors)),
        "frames": len(errors),
        "evaluations_per_frame": int(cfg.tracking.evaluations),
        "optimizer": cfg.optimizer.name,
        "strategy": "hierarchical" if "Hierarchical" in cfg.strategy._target_ else "holistic",
        "dof": cfg.body.dof,
        "backend": cfg.evaluator.name,
        "vertices": cfg.body.vertices,
        "subject": cfg.dataset.subject,
        "action": cfg.dataset.action,
        "seed": cfg.seed,
        "provenance": {
            **provenance.facts(),
            "components": provenance.components({"optimizer": cfg.optimizer.name, "evaluator": cfg.evaluator.name}),
        },
    }


def record_of(cfg, errors, search=2.0, evaluation=1.5, foreground=0.3, fitness=None):
    """``fitness``: each frame's best fitness (0.1 each unless given)."""
    fitness = [0.1] * len(errors) if fitness is None else fitness
    frames = [
        {"frame": k, "marker_error_mm": e, "fitness": f, "evaluations": 10, "seconds": 0.5, "foreground_seconds": 0.1}
        for k, (e, f) in enumerate(zip(errors, fitness))
    ]
    return make_record(
        cfg, summary_of(cfg, errors), frames, search, evaluation, foreground, provenance.now(), Path("run")
    )


# -- HumanEva-I: a tiny synthetic sequence exported to its layout and read back ----------------------

#: the exported tiny sequence of tests/data/humaneva/conftest.py: its cameras, frames, the
#: exporter's default mocap lead and the images before the sequence in an exported video
HE_CAMERAS = ["C1", "BW1"]
HE_FRAMES = 3
HE_LEAD = 4  # the exporter's default mocap lead
HE_LEAD_IN = TOOLBOX_FIRST_FRAME - 1  # images before the sequence in an exported video
HE_FIRST = HE_LEAD + 2 * HE_LEAD_IN  # 0-based mocap frame of the sequence's first frame


def open_he(root, **kwargs):
    """The HumanEva-I folder ``root`` opened as a sequence (the test cameras unless given)."""
    return HumanEvaDataset(root, cameras=kwargs.pop("cameras", HE_CAMERAS), **kwargs).open(progress=False)


# --- recordings ----------------------------------------------------------------------------


def write_masks(root: Path, cameras=None, missing: int = 0, size=None) -> None:
    """``masks/<camera>/`` of blank 8-bit masks, one per frame of each camera's video (less
    ``missing``), at the video's size or ``size`` (width, height)."""
    for video in sorted((root / "videos").glob("*.mp4")):
        if cameras is not None and video.stem not in cameras:
            continue
        capture = cv2.VideoCapture(str(video))
        frames = []
        while (grabbed := capture.read())[0]:
            frames.append(grabbed[1])
        folder = root / "masks" / video.stem
        folder.mkdir(parents=True)
        for k, frame in enumerate(frames[: len(frames) - missing]):
            width, height = size or (frame.shape[1], frame.shape[0])
            cv2.imwrite(str(folder / f"{k:04d}.png"), np.zeros((height, width), np.uint8))


def pad_calibration(root: Path, pixels: int) -> None:
    """Make the calibration say every image is ``pixels`` columns wider than its video (a
    codec's padding at the right), the intrinsics unchanged."""
    calibration = read_calibration(root / "calibration.yml")
    padded = [replace(camera, width=camera.width + pixels, _maps={}) for camera in calibration.cameras]
    write_opencv_yaml(root / "calibration.yml", padded, units="mm")


# --- lab calibration files ------------------------------------------------------------------


def xml_attributes(values: dict) -> str:
    """``key="value" ...``, numbers written to be read back exactly, lists joined by spaces."""

    def text(value) -> str:
        if isinstance(value, (list, tuple, np.ndarray)):
            return " ".join(text(v) for v in value)
        return value if isinstance(value, str) else repr(float(value)) if isinstance(value, float) else str(value)

    return " ".join(f'{key}="{text(value)}"' for key, value in values.items())


def qtm_calibration_xml(cameras, window=(8, 4)) -> str:
    """A Qualisys QTM ``.qca.txt`` of ``cameras`` (mmocap cameras, t in mm), written from the
    format's conventions: each camera's image is the sensor window ``<fov_video>`` starting at
    ``window`` (left, top) of a larger sensor; focal lengths and principal point in 1/64 sensor
    pixels, the centre relative to the sensor's corner; ``<transform>`` holds the camera centre
    and QTM's camera axes in world coordinates, x then y then z (``r11 r12 r13`` is the x
    axis): QTM's camera has y up the image and looks along -z, so its axes are OpenCV's x, -y
    and -z axes (the rows of R, the last two negated)."""
    left, top = window
    blocks = []
    for c in cameras:
        right, bottom = left + c.width - 1, top + c.height - 1
        axes = (c.R[0], -c.R[1], -c.R[2])
        (fx, _, cx), (_, fy, cy), _ = c.K
        k1, k2, p1, p2, k3 = map(float, c.dist)
        camera = {"active": "1", "calibrated": "true", "avg-residual": "0.3", "serial": c.name}
        fov = {"left": left, "top": top, "right": right, "bottom": bottom}
        transform = dict(zip("xyz", map(float, c.centre), strict=True))
        transform |= {f"r{i + 1}{j + 1}": float(axes[i][j]) for i in range(3) for j in range(3)}
        intrinsic = {
            "focallength": "8.0",
            "sensorMinU": "0",
            "sensorMaxU": 64 * (right + left),
            "sensorMinV": "0",
            "sensorMaxV": 64 * (bottom + top),
            "focalLengthU": 64 * float(fx),
            "focalLengthV": 64 * float(fy),
            "centerPointU": 64 * float(cx + left),
            "centerPointV": 64 * float(cy + top),
            "skew": "0",
            "radialDistortion1": k1,
            "radialDistortion2": k2,
            "radialDistortion3": k3,
            "tangentalDistortion1": p1,
            "tangentalDistortion2": p2,
        }
        blocks.append(
            f'    <camera {xml_attributes(camera)} model="Miqus Video" viewrotation="0">\n'
            f"      <fov_video {xml_attributes(fov)}/>\n"
            f"      <transform {xml_attributes(transform)}/>\n"
            f"      <intrinsic {xml_attributes(intrinsic)}/>\n    </camera>\n"
        )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<calibration source="test" type="regular">\n'
        f'  <results std-dev="0.4"/>\n  <cameras>\n{"".join(blocks)}  </cameras>\n</calibration>\n'
    )


def vicon_calibration_xml(cameras) -> str:
    """A Vicon ``.xcp`` of ``cameras`` (mmocap cameras, t in mm, no tangential distortion),
    written from the format's conventions: ``SENSOR_SIZE`` the image size, ``FOCAL_LENGTH``
    fx and ``PIXEL_ASPECT_RATIO`` fx / fy, ``ORIENTATION`` the world-to-camera rotation as the
    quaternion x y z w (from R's axis and angle), ``POSITION`` the camera centre in mm,
    ``VICON_RADIAL2`` the model, its centre (the principal point) and k1 k2 k3."""
    blocks = []
    for index, c in enumerate(cameras, 1):
        rvec = cv2.Rodrigues(c.R)[0].ravel()
        angle = float(np.linalg.norm(rvec))
        axis = rvec / angle if angle else np.zeros(3)
        (fx, _, cx), (_, fy, cy), _ = c.K
        k1, k2, _, _, k3 = map(float, c.dist)
        camera = {
            "DEVICEID": c.name,
            "USERID": index,
            "TYPE": "Vue",
            "PIXEL_ASPECT_RATIO": float(fx / fy),
            "SENSOR_SIZE": [c.width, c.height],
            "SKEW": "0",
        }
        keyframe = {
            "FRAME": 0,
            "FOCAL_LENGTH": float(fx),
            "ORIENTATION": [*map(float, axis * np.sin(angle / 2)), float(np.cos(angle / 2))],
            "POSITION": [*map(float, c.centre)],
            "PRINCIPAL_POINT": [float(cx), float(cy)],
            "VICON_RADIAL2": ["ThirdOrderRadial", float(cx), float(cy), k1, k2, k3],
            "WORLD_ERROR": "0.3",
        }
        blocks.append(
            f"  <Camera {xml_attributes(camera)}>\n"
            f"    <KeyFrames>\n      <KeyFrame {xml_attributes(keyframe)}/>\n    </KeyFrames>\n  </Camera>\n"
        )
    header = '<?xml version="1.0" encoding="UTF-8" standalone="no" ?>\n<Cameras VERSION="1.0">\n'
    return f"{header}{''.join(blocks)}</Cameras>\n"
