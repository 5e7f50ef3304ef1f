"""Standard motion files of a finished tracking run: CSV, TRC, C3D and BVH.

``mmocap export RUN_DIR --format trc,c3d,bvh,csv [--out DIR] [--fps N] [--units mm|m]
[--names mmocap|pose2sim] [--frame world|calibration]`` reads a finished run folder
(``summary.json``, whose ``config`` rebuilds the body model, and ``frames.csv``, the tracked
poses) and writes into ``RUN_DIR/export`` (or ``--out``); a tracking run writes the formats of
its config's ``export`` list there itself, before its ``summary.json``, as its
``export_options`` (:class:`ExportOptions`) say.

Every file is in mmocap's world frame by default: Y up (x to the left, y up, z forward of the
model axes of :mod:`mmocap.body.skeleton`; the rest pose faces +z). ``frame=calibration``
writes every point, and the BVH, in the calibration's own frame instead: a recording's world
before its reader turned ``dataset.up`` to +y (:func:`output_turn`). Frames are numbered from
0 in the CSV files (as in ``frames.csv``) and from 1 in TRC and C3D (their convention); the
time of frame ``f`` is ``f / fps`` seconds, ``fps`` being the tracked sequence's frame rate.

- ``csv``: ``markers_mm.csv`` (frame, marker, x_mm, y_mm, z_mm: the 15 virtual markers in the
  layout of a sequence folder's ground truth, so that it can stand in for one),
  ``joints_mm.csv`` (frame, joint, x_mm, y_mm, z_mm: the 16 joint centres; the column is
  ``joint`` because joint centres are not markers) and ``pose.csv`` (frame, time_s, the 51
  pose parameters in mm and rad, every rotation wrapped to (-pi, pi]; the body model's
  parameters, in mmocap's world whatever the frame).
- ``trc``: ``motion.trc``, the 15 markers then the 16 joint centres in mm (or metres with
  ``units=m``: Pose2Sim reads a TRC's numbers as metres whatever its Units line says), in the
  layout OpenSim's ``TRCFileAdapter`` reads (tabs, the blank sixth line, ``NaN`` for a
  missing value, no trailing tab). ``names=pose2sim`` names them as Pose2Sim does
  (:data:`POSE2SIM_NAMES`) and adds Pose2Sim's ``Hip`` (:data:`POSE2SIM_HIP`).
- ``c3d``: ``motion.c3d``, the same points and names (POINT:UNITS ``mm`` or ``m``, float
  storage; a missing point is written as zeros with residual -1), written with the ``c3d``
  package (``pip install 'mmocap[export]'``).
- ``bvh``: ``motion.bvh``, the 16 joints of :data:`~mmocap.body.skeleton.PARENTS` in metres
  (Blender's unit: it imports at true size with Scale 1; its BVH importer also takes Y up), the
  root with 6 channels, every other joint with ``Zrotation Xrotation Yrotation`` in degrees.
"""

from __future__ import annotations

import argparse
import importlib
import io
import math
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np
import pandas as pd
from hydra.errors import InstantiationException
from hydra.utils import instantiate
from omegaconf import OmegaConf
from scipy.spatial.transform import Rotation

from mmocap.body import skeleton
from mmocap.body.model import BodyModel
from mmocap.data.recording.reader import UP_AXES
from mmocap.data.sequence import write_markers
from mmocap.errors import ConfigError, DataError, MmocapError, MmocapWarning
from mmocap.io import atomic_writer, check_whole_lines, write_text_atomic
from mmocap.run_folder import EXPORT_FOLDER, FRAMES, FRAMES_PARTIAL, SUMMARY, Summary, read_summary
from mmocap.validate import check_choice, check_number

#: the formats :func:`export_run` writes, each into the files of :data:`FILES`
FORMATS = ("csv", "trc", "c3d", "bvh")
#: format -> the names of the files it writes into the export folder
FILES = {
    "csv": ("markers_mm.csv", "joints_mm.csv", "pose.csv"),
    "trc": ("motion.trc",),
    "c3d": ("motion.c3d",),
    "bvh": ("motion.bvh",),
}
#: the Euler order of every BVH rotation: channels ``Zrotation Xrotation Yrotation``, R = Rz Rx Ry
BVH_ROTATION_ORDER = "ZXY"
#: the pip command that installs the C3D writer
C3D_INSTALL = "pip install 'mmocap[export]'"
#: the units the TRC and C3D files are written in (``units``) -> millimetres per unit
MM_PER_UNIT = {"mm": 1.0, "m": 1000.0}
#: how the TRC and C3D files name their points (``names``): mmocap's names, or Pose2Sim's
NAMINGS = ("mmocap", "pose2sim")
#: the frame every exported point is in (``frame``): mmocap's y-up world, or the calibration's own
COORDINATE_FRAMES = ("world", "calibration")
#: ``names=pose2sim``: mmocap's point -> the name of the same point in Pose2Sim's HALPE_26 skeleton
#: (Pose2Sim/skeletons.py) and its OpenSim marker set (OpenSim_Setup/Markers_Halpe26.xml): the top
#: of the head. The 13 joint centres LShoulder ... RWrist, Neck and LHip ... RAnkle already have
#: Pose2Sim's names; mmocap has no Nose, toes or heels.
POSE2SIM_NAMES = {"head": "Head"}
#: ``names=pose2sim`` adds Pose2Sim's ``Hip``, the midpoint of these two joint centres, as Pose2Sim
#: defines it (mmocap's Root pivot lies above it)
POSE2SIM_HIP = ("LHip", "RHip")
#: the C3D screen axes (POINT:X_SCREEN, Y_SCREEN) name these directions of mmocap's world: right, up
SCREEN_DIRECTIONS = (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))


@dataclass(frozen=True)
class ExportOptions:
    """How the exports write their points (``export_options`` in ``conf/config.yaml``; for
    ``mmocap export``, its ``--units``, ``--names`` and ``--frame``): the ``units`` of the TRC
    and C3D files (:data:`MM_PER_UNIT`), the ``names`` of their points (:data:`NAMINGS`) and
    the ``frame`` every point is in (:data:`COORDINATE_FRAMES`). A value that is not one of
    these is a ConfigError naming its ``export_options`` key."""

    units: str = "mm"
    names: str = "mmocap"
    frame: str = "world"

    def __post_init__(self):
        for name, choices in OPTION_CHOICES.items():
            check_choice(f"export_options.{name}", getattr(self, name), choices)


#: each field of :class:`ExportOptions` -> the values it takes
OPTION_CHOICES = {"units": tuple(MM_PER_UNIT), "names": NAMINGS, "frame": COORDINATE_FRAMES}


def check_formats(formats, key: str) -> tuple[str, ...]:
    """``formats`` (a list of names of :data:`FORMATS`) as a tuple, each once, in order; a
    ConfigError naming ``key`` (``export`` in the config, ``--format`` on the command line) for a
    value that is not such a list, an unknown format, or ``c3d`` without the ``c3d`` package."""
    if isinstance(formats, str) or not isinstance(formats, Iterable):
        raise ConfigError(
            f"{key} must be a list of formats from {', '.join(FORMATS)} (e.g. [trc, bvh]), got {formats!r}"
        )
    chosen = tuple(dict.fromkeys(formats))
    unknown = [f for f in chosen if f not in FORMATS]
    if unknown:
        raise ConfigError(f"{key}: unknown format {', '.join(map(repr, unknown))}; choose from {', '.join(FORMATS)}")
    if "c3d" in chosen:
        c3d_writer(key)
    return chosen


def exported_files(folder: Path) -> list[Path]:
    """The export files (:data:`FILES`) and temporary files of an interrupted export in
    ``folder`` that exist: what a run that starts again removes, so that no export of an
    earlier run lies beside its own."""
    names = [name for names in FILES.values() for name in names]
    return [*(p for p in (folder / name for name in names) if p.is_file()), *folder.glob(".*.tmp")]


def c3d_writer(key: str):
    """The ``c3d`` package's ``Writer`` class (c3d >= 0.5); a ConfigError naming ``key`` saying
    how to install it when it is missing or too old."""
    try:
        c3d = importlib.import_module("c3d")
    except ImportError:
        raise ConfigError(
            f"{key}: format c3d needs the c3d package, which is not installed: {C3D_INSTALL}, or leave c3d out"
        ) from None
    writer = getattr(c3d, "Writer", None)
    if writer is None or not hasattr(writer, "set_point_labels"):
        raise ConfigError(f"{key}: format c3d needs c3d>=0.5 (point labels): {C3D_INSTALL} --upgrade")
    return writer


def wrap_angles(poses: np.ndarray) -> np.ndarray:
    """(F, 51) poses -> a copy with every rotation (columns 3:) wrapped to (-pi, pi]; the root
    translation (mm) is kept."""
    wrapped = np.array(poses, dtype=np.float64)
    wrapped[:, 3:] = np.pi - np.mod(np.pi - wrapped[:, 3:], 2 * np.pi)
    return wrapped


def read_poses(path: Path) -> np.ndarray:
    """(F, 51) poses (mm, rad) of a run's ``frames.csv``, whose frames must be 0 ... F-1 in
    order; a DataError naming the file and the column or line that is wrong, or its last line
    when that has no line end (the file may be cut short: :func:`mmocap.io.check_whole_lines`)."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path} not found: the run has not finished")
    data = path.read_bytes()
    check_whole_lines(data, str(path))
    try:
        table = pd.read_csv(io.BytesIO(data))
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise DataError(f"{path} is not a readable CSV table: {' '.join(str(exc).split())}") from None
    columns = ["frame", *skeleton.parameter_names()]
    absent = [c for c in columns if c not in table.columns]
    if absent:
        raise DataError(
            f"{path} lacks the pose column{'s' * (len(absent) > 1)} {', '.join(absent[:6])}"
            f"{' ...' if len(absent) > 6 else ''}; a run's frames.csv has frame and the 51 "
            "parameters of mmocap.body.skeleton.parameter_names()"
        )
    if table.empty:
        raise DataError(f"{path} holds no frames, only its header")
    values = table[columns].apply(pd.to_numeric, errors="coerce").to_numpy(np.float64)
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise DataError(
            f"{path}: column {columns[col]} of line {row + 2} is not a number ({table[columns[col]].iloc[row]!r})"
        )
    if not np.array_equal(values[:, 0], np.arange(len(values))):
        raise DataError(
            f"{path}: column frame must count the frames 0, 1, 2, ... in order; "
            f"it holds {', '.join(f'{f:g}' for f in values[:5, 0])}{' ...' if len(values) > 5 else ''}"
        )
    return values[:, 1:]


def export_run(
    run_dir: str | Path,
    formats: Sequence[str],
    out_dir: str | Path | None = None,
    fps: float | None = None,
    units: str | None = None,
    names: str | None = None,
    frame: str | None = None,
) -> list[Path]:
    """Write ``formats`` (from :data:`FORMATS`) of the finished run in ``run_dir`` into
    ``out_dir`` (default ``run_dir/export``); returns the paths written.

    ``fps`` overrides the frame rate that ``summary.json`` records (a summary written before it
    did needs it). ``units``, ``names`` and ``frame`` (see :class:`ExportOptions`) override
    the run's ``export_options``; None keeps the run's (the default for a run whose summary
    predates them). A DataError names the file when ``run_dir`` is not a finished run (no
    ``summary.json``; no ``frames.csv``, only ``frames.csv.partial``) or a file is malformed; a
    ConfigError names ``--format``, ``--fps``, ``--units``, ``--names`` or ``--frame`` for a
    bad value.
    """
    formats = check_formats(formats, "--format")
    if fps is not None:
        fps = check_number("--fps", fps, 0, low_open=True)
    given = {
        name: check_choice(f"--{name}", value, OPTION_CHOICES[name])
        for name, value in {"units": units, "names": names, "frame": frame}.items()
        if value is not None
    }
    run_dir = Path(run_dir)
    summary_path, frames_path = run_dir / SUMMARY, run_dir / FRAMES
    if not run_dir.is_dir():
        raise DataError(f"run folder {run_dir} not found")
    if not summary_path.is_file() or not frames_path.is_file():
        what = (
            f"it holds {FRAMES_PARTIAL}, the frames of a run that stopped"
            if (run_dir / FRAMES_PARTIAL).is_file()
            else f"{SUMMARY} is missing"
            if not summary_path.is_file()
            else f"{FRAMES} is missing"
        )
        raise DataError(
            f"{run_dir} is not a finished run ({what}); export a folder where a tracking run "
            f"wrote {SUMMARY} and {FRAMES}, or run it again"
        )
    summary = read_summary(run_dir)
    recorded_fps = summary.fps
    if recorded_fps is not None:
        recorded_fps = check_number(f"fps in {summary_path}", recorded_fps, 0, low_open=True)
    if fps is None:
        if recorded_fps is None:
            raise DataError(
                f"{summary_path} does not record the frame rate (fps), as an older mmocap wrote it: "
                "pass --fps N, the tracked sequence's frames per second"
            )
        fps = recorded_fps
    elif recorded_fps is not None and not math.isclose(fps, recorded_fps):
        warnings.warn(
            f"--fps {fps:g} differs from the run's {recorded_fps:g} frames per second "
            f"({summary_path}); the exported times use {fps:g}",
            MmocapWarning,
            stacklevel=2,
        )
    chosen = replace(run_options(summary, summary_path), **given)
    body = run_body(summary, summary_path)
    poses = read_poses(frames_path)
    out = run_dir / EXPORT_FOLDER if out_dir is None else Path(out_dir)
    return export_motion(out, formats, body, poses, fps, options=chosen, up=run_up(summary, summary_path))


def run_options(summary: Summary, summary_path: Path) -> ExportOptions:
    """The :class:`ExportOptions` the run was configured with (the summary's
    ``config.export_options``; the defaults where it has none, as older summaries)."""
    recorded = summary.config.get("export_options")
    names = {f.name for f in fields(ExportOptions)}
    values = {k: v for k, v in recorded.items() if k in names} if isinstance(recorded, dict) else {}
    try:
        return ExportOptions(**values)
    except ConfigError as exc:
        raise DataError(f"{summary_path}: config.{exc}") from None


def run_up(summary: Summary, summary_path: Path) -> str | None:
    """The run's ``dataset.up`` (a recording's: the calibration world's up axis, a key of
    :data:`~mmocap.data.recording.reader.UP_AXES`), None for a dataset that has none."""
    dataset = summary.config.get("dataset")
    up = dataset.get("up") if isinstance(dataset, dict) else None
    if up is not None and up not in UP_AXES:
        raise DataError(f"{summary_path}: config.dataset.up is {up!r}, not one of {', '.join(UP_AXES)}")
    return up


def run_body(summary: Summary, summary_path: Path) -> BodyModel:
    """The run's body model from the summary's ``config.body``, with the height and girth the
    run tracked with (``body`` in the summary: an automatic start may have fitted them)."""
    if not isinstance(summary.config.get("body"), dict):
        raise DataError(
            f"{summary_path} has no config.body, the run's body model; it is not the summary of a tracking run"
        )
    fitted = summary.body
    shape = {k: fitted[k] for k in ("height_mm", "girth") if k in fitted} if isinstance(fitted, dict) else {}
    try:
        return instantiate(OmegaConf.create(summary.config["body"]), **shape)
    except (MmocapError, InstantiationException) as exc:
        cause = exc.__cause__ if isinstance(exc, InstantiationException) and exc.__cause__ else exc
        raise DataError(f"{summary_path}: config.body does not build the body model: {cause}") from None


def output_turn(frame: str, up: str | None) -> np.ndarray:
    """(3, 3) rotation taking mmocap's world to the exports' ``frame``
    (:data:`COORDINATE_FRAMES`): the identity for ``world``; for ``calibration`` the inverse of
    the turn a recording's reader gave its calibration's world
    (:data:`~mmocap.data.recording.reader.UP_AXES` of ``up``, the run's ``dataset.up``). A run
    without ``up`` (synthetic, folder and HumanEva sequences) was tracked in its calibration's
    world: the identity too."""
    if frame == "world" or up is None:
        return np.eye(3)
    return UP_AXES[up].T


def screen_axes(turn: np.ndarray) -> tuple[str, str]:
    """The C3D's POINT:X_SCREEN and Y_SCREEN (``"+X"``, ``"-Z"`` ...): the axes of the frame
    that ``turn`` (3, 3, a signed permutation) takes mmocap's world to, along mmocap's
    :data:`SCREEN_DIRECTIONS` (right, up)."""
    names = []
    for direction in SCREEN_DIRECTIONS:
        axis = turn @ direction
        k = int(np.argmax(np.abs(axis)))
        names.append(f"{'+' if axis[k] > 0 else '-'}{'XYZ'[k]}")
    return names[0], names[1]


def named_points(body: BodyModel, poses: np.ndarray, names: str) -> tuple[np.ndarray, list[str]]:
    """(F, M, 3) points (mm, mmocap's world) of the TRC and C3D files of the (F, 51) ``poses``,
    and their M names, as ``names`` (:data:`NAMINGS`) says: the 15 markers of ``body`` then the
    16 joint centres of :data:`~mmocap.body.skeleton.JOINTS` (M = 31); for ``pose2sim``, renamed
    by :data:`POSE2SIM_NAMES`, then Pose2Sim's ``Hip`` (:data:`POSE2SIM_HIP`; M = 32)."""
    joints = body.joint_positions(poses)
    points = np.concatenate([body.markers(poses), joints], axis=1)
    labels = [*body.marker_names, *skeleton.JOINTS]
    if names == "pose2sim":
        hip = joints[:, [skeleton.JOINTS.index(j) for j in POSE2SIM_HIP]].mean(axis=1)
        points = np.concatenate([points, hip[:, None]], axis=1)
        labels = [*(POSE2SIM_NAMES.get(n, n) for n in labels), "Hip"]
    return points, labels


def export_motion(
    out_dir: Path,
    formats: Sequence[str],
    body: BodyModel,
    poses: np.ndarray,
    fps: float,
    key: str = "export",
    options: ExportOptions | None = None,
    up: str | None = None,
) -> list[Path]:
    """Write ``formats`` of the (F, 51) ``poses`` (mm, rad) of ``body``, frames 0 ... F-1 at
    ``fps`` frames per second, into ``out_dir``, as ``options`` say (None: the defaults of
    :class:`ExportOptions`); returns the paths written (:data:`FILES`). ``up`` is the run's
    ``dataset.up`` (None if its dataset has none), which ``frame=calibration`` turns back
    (:func:`output_turn`). ``key`` names the setting that chose the formats in a ConfigError."""
    formats = check_formats(formats, key)
    options = ExportOptions() if options is None else options
    out_dir = Path(out_dir)
    poses = np.atleast_2d(np.asarray(poses, dtype=np.float64))
    turn = output_turn(options.frame, up)
    points, names = named_points(body, poses, options.names)
    points = points @ turn.T
    written = []
    for name in formats:
        if name == "csv":
            written += write_csv(out_dir, body, poses, fps, turn)
        elif name == "trc":
            written.append(write_trc(out_dir / "motion.trc", points, names, fps, options.units))
        elif name == "c3d":
            c3d_path = out_dir / "motion.c3d"
            written.append(write_c3d(c3d_path, points, names, fps, options.units, screen_axes(turn), key))
        else:
            written.append(write_bvh(out_dir / "motion.bvh", body, poses, fps, turn))
    return written


def write_csv(out_dir: Path, body: BodyModel, poses: np.ndarray, fps: float, turn: np.ndarray) -> list[Path]:
    """``markers_mm.csv``, ``joints_mm.csv`` (long tables, mm, 3 decimals, in the frame that
    the (3, 3) rotation ``turn`` takes mmocap's world to) and ``pose.csv`` (frame, time_s, the
    51 parameters, 6 decimals) of the (F, 51) ``poses`` into ``out_dir``.

    ``pose.csv`` wraps every rotation to (-pi, pi]: ``frames.csv`` keeps the angles as the
    tracker left them, where the root's yaw grows past pi as the subject turns. Its parameters
    are the body model's, in mmocap's world whatever ``turn``.
    """
    markers_path, joints_path, pose_path = (out_dir / name for name in FILES["csv"])
    write_markers(markers_path, body.markers(poses) @ turn.T, body.marker_names)  # atomic
    joints = body.joint_positions(poses) @ turn.T
    F, J, _ = joints.shape
    table = pd.DataFrame(
        {
            "frame": np.repeat(np.arange(F), J),
            "joint": np.tile(np.asarray(skeleton.JOINTS), F),
            "x_mm": joints[..., 0].ravel(),
            "y_mm": joints[..., 1].ravel(),
            "z_mm": joints[..., 2].ravel(),
        }
    )
    write_text_atomic(joints_path, table.to_csv(index=False, float_format="%.3f"))
    pose = pd.DataFrame(wrap_angles(poses), columns=skeleton.parameter_names())
    pose.insert(0, "time_s", np.arange(F) / fps)
    pose.insert(0, "frame", np.arange(F))
    write_text_atomic(pose_path, pose.to_csv(index=False, float_format="%.6f"))
    return [markers_path, joints_path, pose_path]


def write_trc(path: Path, points: np.ndarray, names: Sequence[str], fps: float, units: str) -> Path:
    """Write (F, M, 3) ``points`` (mm, NaN = missing) named ``names`` (M, no whitespace) at
    ``fps`` as a TRC file in ``units`` (a key of :data:`MM_PER_UNIT`: its numbers and its
    Units line; Frame# from 1, Time = (Frame# - 1) / fps s) in the layout OpenSim's
    TRCFileAdapter, Pose2Sim and pandas all read; returns ``path``."""
    F, M, _ = points.shape
    rate = f"{fps:g}"
    header = [
        f"PathFileType\t4\t(X/Y/Z)\t{Path(path).name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
        f"{rate}\t{rate}\t{F}\t{M}\t{units}\t{rate}\t1\t{F}",
        "Frame#\tTime\t" + "".join(f"{name}\t\t\t" for name in names),
        "\t\t" + "".join(f"X{m}\tY{m}\tZ{m}\t" for m in range(1, M + 1)),
        "",
    ]
    values = points / MM_PER_UNIT[units]
    rows = [
        f"{f + 1}\t{f / fps:.6f}\t" + "\t".join("NaN" if math.isnan(v) else f"{v:.6f}" for v in frame)
        for f, frame in enumerate(values.reshape(F, -1).tolist())
    ]
    return write_text_atomic(path, "\n".join(header + rows) + "\n")


def write_c3d(
    path: Path,
    points: np.ndarray,
    names: Sequence[str],
    fps: float,
    units: str,
    screen: tuple[str, str],
    key: str = "--format",
) -> Path:
    """Write (F, M, 3) ``points`` (mm) named ``names`` at ``fps`` as a C3D file in ``units``
    (a key of :data:`MM_PER_UNIT`, POINT:UNITS), float storage, first frame 1, screen axes
    ``screen`` (POINT:X_SCREEN, Y_SCREEN, e.g. ``("+X", "+Y")``); returns ``path``. A point
    with a NaN coordinate is missing: zeros with residual -1 on disk, so that a reader that
    ignores the residual does not take it for a real position either. ``key`` names the
    setting that asked for C3D in the ConfigError of a missing ``c3d`` package."""
    writer = c3d_writer(key)(point_rate=float(fps), analog_rate=0.0, point_scale=-1.0, point_units=units)
    writer.set_point_labels(list(names))
    writer.set_screen_axis(X=screen[0], Y=screen[1])
    writer.set_start_frame(1)
    no_analog = np.zeros((0, 0), np.float32)
    missing = ~np.isfinite(points).all(axis=2)  # (F, M)
    for frame, absent in zip(points / MM_PER_UNIT[units], missing):
        rows = np.zeros((len(frame), 5), np.float32)  # x, y, z, residual, camera mask
        rows[:, :3] = np.where(absent[:, None], 0.0, frame)
        rows[absent, 3] = -1.0
        writer.add_frames([(rows, no_analog)])
    with atomic_writer(path, "wb") as f, warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="No analog data", category=UserWarning)  # none is meant
        writer.write(f)
        # the c3d package writes every frame from one buffer, where a missing point keeps the
        # coordinates of the frame before: zero them on disk (a frame is its points, 4 float32
        # words each, as there is no analog data)
        start = (int(writer.header.data_block) - 1) * 512
        zeros = np.zeros(3, "<f4").tobytes()
        for frame, point in np.argwhere(missing):
            f.seek(start + (int(frame) * len(names) + int(point)) * 16)
            f.write(zeros)
    return Path(path)


def depth_first_joints() -> list[int]:
    """Indices into :data:`~mmocap.body.skeleton.JOINTS` in BVH order: depth first from the
    root, children in the order of JOINTS."""
    order, stack = [], [int(np.flatnonzero(skeleton.PARENT_INDEX < 0)[0])]
    while stack:
        j = stack.pop()
        order.append(j)
        stack += reversed(np.flatnonzero(skeleton.PARENT_INDEX == j).tolist())
    return order


def bvh_channels(body: BodyModel, poses: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """(F, 51) poses -> (F, 3 + 3 * 16) BVH channel values in the joint order of
    :func:`depth_first_joints`, in the frame that the (3, 3) rotation ``turn`` takes mmocap's
    world to: the root pivot's position in metres, then per joint the ``Zrotation Xrotation
    Yrotation`` angles in degrees of ``L_j = G_parent^T G_j`` (G = turn G_world turn^T, G_world
    the rotation of the joint's rest-to-world transform; the root's parent is the frame). Every
    joint's BVH rest orientation is the frame's axes, as every rest frame of
    :mod:`mmocap.body.kinematics` is the identity rotation at the rest pose."""
    G = turn @ body.transforms(poses)[..., :3, :3] @ turn.T  # (F, 16, 3, 3)
    parent = skeleton.PARENT_INDEX
    local = G.copy()
    has_parent = parent >= 0
    local[:, has_parent] = np.swapaxes(G[:, parent[has_parent]], -1, -2) @ G[:, has_parent]
    with warnings.catch_warnings():  # at gimbal lock scipy zeroes the last angle: still R = Rz Rx Ry
        warnings.filterwarnings("ignore", message="Gimbal lock", category=UserWarning)
        angles = Rotation.from_matrix(local.reshape(-1, 3, 3)).as_euler(BVH_ROTATION_ORDER, degrees=True)
    angles = angles.reshape(len(poses), len(skeleton.JOINTS), 3)[:, depth_first_joints()]
    root = int(np.flatnonzero(parent < 0)[0])
    position_m = body.joint_positions(poses)[:, root] @ turn.T / 1000.0
    return np.concatenate([position_m, angles.reshape(len(poses), -1)], axis=1)


def write_bvh(path: Path, body: BodyModel, poses: np.ndarray, fps: float, turn: np.ndarray) -> Path:
    """Write the (F, 51) ``poses`` of ``body`` as a BVH file in metres, in the frame that the
    (3, 3) rotation ``turn`` takes mmocap's world to: the HIERARCHY of the 16 joints (OFFSETs
    from the rest pivots, ROOT OFFSET 0 0 0 so that its position channels are the root pivot's
    position; an End Site at the segment end of every leaf joint), then MOTION with Frame Time
    1/fps (:func:`bvh_channels`); returns ``path``."""
    rest_m = np.asarray(body.joint_rest_positions, dtype=np.float64) @ turn.T / 1000.0
    ends_m = np.asarray(body.mesh.segment_ends, dtype=np.float64) @ turn.T / 1000.0
    parent = skeleton.PARENT_INDEX
    lines = ["HIERARCHY"]

    def vector(v) -> str:
        return " ".join(f"{x:.6f}" for x in v)

    def declare(j: int, depth: int) -> None:
        pad = "\t" * depth
        is_root = parent[j] < 0
        lines.append(f"{pad}{'ROOT' if is_root else 'JOINT'} {skeleton.JOINTS[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {vector(np.zeros(3) if is_root else rest_m[j] - rest_m[parent[j]])}")
        rotations = " ".join(f"{axis}rotation" for axis in BVH_ROTATION_ORDER)
        lines.append(
            f"{pad}\tCHANNELS 6 Xposition Yposition Zposition {rotations}"
            if is_root
            else f"{pad}\tCHANNELS 3 {rotations}"
        )
        children = np.flatnonzero(parent == j)
        for child in children:
            declare(int(child), depth + 1)
        if children.size == 0:
            lines.extend(
                [f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET {vector(ends_m[j] - rest_m[j])}", f"{pad}\t}}"]
            )
        lines.append(f"{pad}}}")

    declare(depth_first_joints()[0], 0)
    lines += ["MOTION", f"Frames: {len(poses)}", f"Frame Time: {1.0 / fps:.8f}"]
    motion = io.StringIO()
    np.savetxt(motion, bvh_channels(body, poses, turn), fmt="%.6f", delimiter=" ")
    return write_text_atomic(path, "\n".join(lines) + "\n" + motion.getvalue())


def main(argv: list[str], prog: str) -> None:
    """``mmocap export RUN_DIR [--format ...] [--out DIR] [--fps FPS] [--units U] [--names N]
    [--frame F]``: write a finished run's motion as TRC, C3D, BVH and CSV files."""
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Write a finished run's motion as CSV, TRC (OpenSim, Pose2Sim), C3D and BVH (Blender) "
        "files, in mmocap's Y-up world frame or the calibration's.",
    )
    parser.add_argument("run_dir", type=Path, help=f"a finished run folder ({SUMMARY} and {FRAMES})")
    parser.add_argument(
        "--format", default=",".join(FORMATS), help=f"comma-separated formats from {', '.join(FORMATS)} (default: all)"
    )
    parser.add_argument("--out", type=Path, help="the folder to write into (default: RUN_DIR/export)")
    parser.add_argument(
        "--fps", type=float, help=f"frames per second of the tracked sequence (default: {SUMMARY}'s fps)"
    )
    helps = {
        "units": "the TRC's and C3D's units; Pose2Sim reads a TRC in m",
        "names": "the TRC's and C3D's point names; pose2sim: Pose2Sim's HALPE_26 names where mmocap has the point",
        "frame": "world: mmocap's, Y up; calibration: the calibration's own (dataset.up turned back)",
    }
    for name, choices in OPTION_CHOICES.items():
        parser.add_argument(
            f"--{name}",
            help=f"{' or '.join(choices)}: {helps[name]} (default: the run's export_options.{name}, "
            f"else {getattr(ExportOptions, name)})",
        )
    args = parser.parse_args(argv)
    formats = [f.strip() for f in args.format.split(",") if f.strip()]
    if not formats:
        raise ConfigError(f"--format names no format; choose from {', '.join(FORMATS)}")
    for path in export_run(args.run_dir, formats, args.out, args.fps, args.units, args.names, args.frame):
        print(path)
