"""Motion-file exports of a finished run, each read back by an independent reader: TRC by a
plain parser written here and by Pose2Sim's own reader (from its wheel on the package index),
C3D by ezc3d and by the c3d package's reader, BVH by bvhio (its own forward kinematics), CSV
by pandas and by mmocap's ground-truth reader."""

from __future__ import annotations

import ast
import errno
import json
import logging
import math
import subprocess
import sys
import warnings
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import bvhio
import c3d
import ezc3d
import numpy as np
import pandas as pd
import pytest
from hydra.errors import InstantiationException
from hypothesis import given, settings
from hypothesis import strategies as st
from omegaconf import OmegaConf

from mmocap.body import skeleton
from mmocap.body.model import BodyModel
from mmocap.config import compose
from mmocap.data.recording.commands import POSE2SIM_WHEEL
from mmocap.data.recording.reader import UP_AXES
from mmocap.data.sequence import read_markers
from mmocap.errors import ConfigError, DataError
from mmocap.io import WriteError
from mmocap.preflight import check_config
from mmocap.stages.accuracy import FrameLog
from mmocap.writers import export
from mmocap.writers.export import (
    FORMATS,
    NAMINGS,
    POSE2SIM_NAMES,
    ExportOptions,
    export_motion,
    export_run,
    read_poses,
    write_c3d,
    write_trc,
)
from tests.helpers import Outcome, assert_clean_error, damages, mmocap, read_damaged, run_cli

FPS = 50.0
#: a complete summary.json, of a run of the demo config on a tiny sequence
SUMMARY_EXAMPLE = Path(__file__).parents[1] / "golden" / "data" / "summary.json"
ROOT_YAW = 6.77  # rad: a subject that turned more than once; pose.csv wraps it to 6.77 - 2 pi


@pytest.fixture(scope="module")
def body() -> BodyModel:
    return BodyModel("S1", vertices=1000)


@pytest.fixture(scope="module")
def poses(body) -> np.ndarray:
    """(4, 51) poses: the rest pose moved, with random rotations within the joint limits,
    one with the root's yaw past 2 pi; rounded as frames.csv stores them."""
    rng = np.random.default_rng(7)
    lower, upper = skeleton.limits()
    lower, upper = np.maximum(lower, -1.0), np.minimum(upper, 1.0)
    X = np.tile(body.rest_pose(), (4, 1))
    X[:, :3] += rng.normal(0.0, 150.0, (4, 3))
    X[:, 3:] = rng.uniform(lower[3:], upper[3:], (4, 48))
    X[2, skeleton.parameter_index("Root.ry")] = ROOT_YAW
    return np.round(X, 6)


def write_run(folder, poses, *, fps: float | None = FPS, body_facts: dict | None = None, overrides=()):
    """A finished run folder as a tracking run leaves it: frames.csv (by FrameLog) and a
    summary.json with the composed config (body.vertices=1000 and ``overrides``)."""
    log = FrameLog(folder / "frames.csv")
    for frame, pose in enumerate(poses):
        log.write(frame, 1.0, 0.5, 60, 0.01, pose)
    log.close()
    summary = {
        **json.loads(SUMMARY_EXAMPLE.read_text()),
        "config": OmegaConf.to_container(compose(["body.vertices=1000", *overrides]), resolve=True),
        "fps": fps,
        "body": body_facts,
    }
    for key in ("fps", "body"):
        if summary[key] is None:
            del summary[key]
    (folder / "summary.json").write_text(json.dumps(summary))
    return folder


@pytest.fixture(scope="module")
def exported(tmp_path_factory, poses):
    """The run folder, with every format exported into its default folder."""
    run = write_run(tmp_path_factory.mktemp("run"), poses)
    return run, export_run(run, FORMATS)


def parse_trc(path):
    """(header dict, marker names, (F, M, 3) values, frame numbers, times), read as its
    specification lays it out (tabs; values from line 7; NaN tokens)."""
    lines = path.read_text().split("\n")
    assert lines[0].split("\t")[0] == "PathFileType"
    assert lines[0].split("\t")[1] == "4"
    keys, values = lines[1].split("\t"), lines[2].split("\t")
    assert keys == [
        "DataRate",
        "CameraRate",
        "NumFrames",
        "NumMarkers",
        "Units",
        "OrigDataRate",
        "OrigDataStartFrame",
        "OrigNumFrames",
    ]
    header = dict(zip(keys, values))
    name_cells = lines[3].split("\t")
    assert name_cells[:2] == ["Frame#", "Time"]
    names = [c for c in name_cells[2:] if c]
    assert name_cells[2:] == [cell for name in names for cell in (name, "", "")] + [""]  # name and two tabs
    m = len(names)
    assert lines[4].split("\t") == ["", ""] + [f"{a}{i}" for i in range(1, m + 1) for a in "XYZ"] + [""]
    assert lines[5] == ""
    rows = [line.split("\t") for line in lines[6:] if line]
    assert lines[-1] == ""
    assert all(len(r) == 2 + 3 * m for r in rows)
    data = np.array([[float(v) for v in r[2:]] for r in rows]).reshape(len(rows), m, 3)
    return header, names, data, [int(r[0]) for r in rows], [float(r[1]) for r in rows]


def test_trc_has_opensim_header_names_and_the_model_points(exported, body, poses):
    run, _ = exported
    header, names, data, frames, times = parse_trc(run / "export" / "motion.trc")
    assert header == {
        "DataRate": "50",
        "CameraRate": "50",
        "NumFrames": "4",
        "NumMarkers": "31",
        "Units": "mm",
        "OrigDataRate": "50",
        "OrigDataStartFrame": "1",
        "OrigNumFrames": "4",
    }
    assert names == [*body.marker_names, *skeleton.JOINTS]
    assert frames == [1, 2, 3, 4]
    assert times == pytest.approx([0.0, 0.02, 0.04, 0.06])
    np.testing.assert_allclose(data[:, :15], body.markers(poses), atol=1e-3, rtol=0)
    np.testing.assert_allclose(data[:, 15:], body.joint_positions(poses), atol=1e-3, rtol=0)


def test_trc_writes_a_missing_value_as_nan(tmp_path):
    points = np.arange(2 * 2 * 3, dtype=float).reshape(2, 2, 3)
    points[1, 1] = np.nan  # the last marker of the last frame: its row must keep every field
    write_trc(tmp_path / "m.trc", points, ["a", "b"], 100.0, "mm")
    assert (tmp_path / "m.trc").read_text().splitlines()[-1].split("\t")[-3:] == ["NaN"] * 3
    np.testing.assert_array_equal(parse_trc(tmp_path / "m.trc")[2], points)


def test_c3d_read_back_with_ezc3d(exported, body, poses):
    run, _ = exported
    c = ezc3d.c3d(str(run / "export" / "motion.c3d"))
    point = c["parameters"]["POINT"]
    assert point["LABELS"]["value"] == [*body.marker_names, *skeleton.JOINTS]
    assert point["UNITS"]["value"] == ["mm"]
    assert point["RATE"]["value"][0] == FPS
    assert c["header"]["points"]["first_frame"] == 0
    assert c["header"]["points"]["last_frame"] == 3
    got = c["data"]["points"][:3].transpose(2, 1, 0)  # (frames, points, xyz)
    expected = np.concatenate([body.markers(poses), body.joint_positions(poses)], axis=1)
    np.testing.assert_allclose(got, expected, atol=1e-3, rtol=0)


def test_c3d_missing_point_is_zeros_with_residual_minus_one_on_disk(tmp_path):
    """Point b is present in frame 1, missing in frame 2: the c3d package's frame buffer held
    frame 1's coordinates there, which a reader that ignores the residual (as Pose2Sim's
    c3d_to_trc does, through the c3d package's reader) took for a position."""
    points = np.array([[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], [[7.0, 8.0, 9.0], [np.nan, 0.0, 1.0]]])
    write_c3d(tmp_path / "m.c3d", points, ["a", "b"], 120.0, "mm", ("+X", "+Y"))
    data = ezc3d.c3d(str(tmp_path / "m.c3d"))["data"]
    got = data["points"][:3].transpose(2, 1, 0)
    expected = points.copy()
    expected[1, 1] = np.nan  # a point with any coordinate missing is invalid as a whole
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(data["meta_points"]["residuals"][0].T, [[0.0, 0.0], [0.0, -1.0]])
    with open(tmp_path / "m.c3d", "rb") as handle, warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="No analog data", category=UserWarning)
        raw = [frame_points[:, :4] for _, frame_points, _ in c3d.Reader(handle).read_frames()]
    np.testing.assert_array_equal(raw, [[[1, 2, 3, 0], [4, 5, 6, 0]], [[7, 8, 9, 0], [0, 0, 0, -1]]])


def test_c3d_in_metres(tmp_path):
    points = np.array([[[1000.0, -2500.0, 30.0]]])
    write_c3d(tmp_path / "m.c3d", points, ["a"], 60.0, "m", ("+X", "+Y"))
    c = ezc3d.c3d(str(tmp_path / "m.c3d"))
    assert c["parameters"]["POINT"]["UNITS"]["value"] == ["m"]
    np.testing.assert_allclose(c["data"]["points"][:3, 0, 0], [1.0, -2.5, 0.03], rtol=1e-6)


def test_bvh_read_with_bvhio_gives_the_joint_centres(exported, body, poses):
    run, _ = exported
    path = str(run / "export" / "motion.bvh")
    structure = bvhio.readAsBvh(path)
    assert structure.FrameCount == 4
    assert structure.FrameTime == pytest.approx(1 / FPS, abs=1e-8)
    assert structure.Root.Name == "Root"
    assert len(structure.Root.Channels) == 6
    root = bvhio.readAsHierarchy(path)
    expected = body.joint_positions(poses) / 1000.0  # BVH in metres
    for frame in range(len(poses)):
        root.loadPose(frame, recursive=True)
        world = {joint.Name: np.array(joint.PositionWorld) for joint, _, _ in root.layout()}
        assert set(world) == set(skeleton.JOINTS)
        got = np.array([world[name] for name in skeleton.JOINTS])
        np.testing.assert_allclose(got, expected[frame], atol=1e-4, rtol=0)  # 0.1 mm
    root.loadRestPose(recursive=True)
    rest = {joint.Name: np.array(joint.PositionWorld) for joint, _, _ in root.layout()}
    np.testing.assert_allclose(
        [rest[n] for n in skeleton.JOINTS], body.joint_rest_positions / 1000.0, atol=1e-5
    )  # offsets written to the micrometre


def test_csv_tables_hold_the_points_and_wrapped_angles(exported, body, poses):
    run, paths = exported
    folder = run / "export"
    assert paths == [
        folder / n for n in ("markers_mm.csv", "joints_mm.csv", "pose.csv", "motion.trc", "motion.c3d", "motion.bvh")
    ]
    # the markers read back as a sequence's ground truth
    markers = read_markers(folder / "markers_mm.csv", len(poses), list(body.marker_names))
    np.testing.assert_allclose(markers, body.markers(poses), atol=1e-3, rtol=0)
    joints = pd.read_csv(folder / "joints_mm.csv")
    assert list(joints.columns) == ["frame", "joint", "x_mm", "y_mm", "z_mm"]
    assert list(joints["joint"][:16]) == list(skeleton.JOINTS)
    got = joints[["x_mm", "y_mm", "z_mm"]].to_numpy().reshape(len(poses), 16, 3)
    np.testing.assert_allclose(got, body.joint_positions(poses), atol=1e-3, rtol=0)

    pose = pd.read_csv(folder / "pose.csv")
    assert list(pose.columns) == ["frame", "time_s", *skeleton.parameter_names()]
    assert list(pose["frame"]) == [0, 1, 2, 3]
    assert list(pose["time_s"]) == pytest.approx([0, 0.02, 0.04, 0.06])
    angles = pose.to_numpy()[:, 5:]
    assert (angles > -math.pi).all()
    assert (angles <= math.pi).all()
    assert pose["Root.ry"][2] == pytest.approx(ROOT_YAW - 2 * math.pi, abs=1e-6)
    np.testing.assert_allclose(pose.to_numpy()[:, 2:5], poses[:, :3], atol=1e-6)  # translations kept
    np.testing.assert_allclose(np.cos(angles), np.cos(poses[:, 3:]), atol=1e-5)
    np.testing.assert_allclose(np.sin(angles), np.sin(poses[:, 3:]), atol=1e-5)


def test_wrap_angles_ends(body):
    poses = np.zeros((1, 51))
    poses[0, 3:7] = [math.pi, -math.pi, 3 * math.pi, -0.5]
    assert export.wrap_angles(poses)[0, 3:7] == pytest.approx([math.pi, math.pi, math.pi, -0.5])


def test_the_body_is_rebuilt_with_the_run_s_fitted_height(tmp_path, poses):
    """An automatic start fits the height: the summary's body, not the config's, is exported."""
    run = write_run(tmp_path, poses[:1], body_facts={"preset": "S1", "height_mm": 1650.0, "girth": 1.05})
    export_run(run, ["csv"])
    tall = BodyModel("S1", vertices=1000, height_mm=1650.0, girth=1.05)
    joints = pd.read_csv(run / "export" / "joints_mm.csv")[["x_mm", "y_mm", "z_mm"]].to_numpy()
    np.testing.assert_allclose(joints, tall.joint_positions(poses[:1])[0], atol=1e-3)


def test_an_older_summary_needs_fps(tmp_path, poses):
    run = write_run(tmp_path, poses, fps=None)
    with pytest.raises(DataError, match="--fps"):
        export_run(run, ["trc"])
    export_run(run, ["trc"], out_dir=tmp_path / "out", fps=25.0)
    assert parse_trc(tmp_path / "out" / "motion.trc")[0]["DataRate"] == "25"


def test_a_failed_write_leaves_no_half_file(tmp_path, body, poses, monkeypatch):
    import c3d

    def fail_midway(self, handle):
        handle.write(b"\0" * 100)
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(c3d.Writer, "_write_frames", fail_midway)
    with pytest.raises(WriteError, match="motion.c3d.*disk is full"):
        export_motion(tmp_path, ["c3d"], body, poses, FPS)
    assert list(tmp_path.iterdir()) == []


def test_bad_export_setting_is_a_config_error():
    with pytest.raises(ConfigError, match="export: unknown format 'fbx'"):
        check_config(compose(["export=[trc,fbx]"]))
    with pytest.raises(ConfigError, match="export must be a list"):
        check_config(compose(["export=trc"]))


def test_read_poses_names_a_cell_that_is_not_a_number(tmp_path, poses):
    write_run(tmp_path, poses[:2])
    text = (tmp_path / "frames.csv").read_text().splitlines()
    cells = text[2].split(",")
    cells[6] = "oops"  # frame, 4 run columns, Root.tx, Root.ty
    (tmp_path / "frames.csv").write_text("\n".join([*text[:2], ",".join(cells)]) + "\n")
    with pytest.raises(DataError, match=r"frames.csv: column Root.ty of line 3 is not a number"):
        read_poses(tmp_path / "frames.csv")


def test_cli_export_writes_the_files(exported, tmp_path):
    run, _ = exported
    out = tmp_path / "motion"
    done = mmocap("export", run, "--format", "trc,bvh", "--out", out, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [str(out / "motion.trc"), str(out / "motion.bvh")]
    assert (out / "motion.trc").read_text() == (run / "export" / "motion.trc").read_text()
    assert "warning" not in done.stderr


def _without_fps(run):
    summary = json.loads((run / "summary.json").read_text())
    del summary["fps"]
    (run / "summary.json").write_text(json.dumps(summary))


def _drop_pose_column(run):
    table = pd.read_csv(run / "frames.csv").drop(columns=["LKnee.rx"])
    table.to_csv(run / "frames.csv", index=False)


def _edit_config(run, edit):
    summary = json.loads((run / "summary.json").read_text())
    edit(summary["config"])
    (run / "summary.json").write_text(json.dumps(summary))


def _stopped_run(run):
    (run / "frames.csv").rename(run / "frames.csv.partial")
    (run / "summary.json").unlink()


# case id -> (how to break a finished run, extra arguments, what the error line must name)
BAD_EXPORTS = {
    "no-run-folder": (lambda run: run.rename(run.with_name("gone")), [], ["not found"]),
    "no-summary": (lambda run: (run / "summary.json").unlink(), [], ["summary.json", "not a finished run"]),
    "only-frames-partial": (_stopped_run, [], ["frames.csv.partial", "not a finished run"]),
    "unknown-format": (lambda run: None, ["--format", "trc,fbx"], ["--format", "fbx"]),
    "empty-format": (lambda run: None, ["--format", ","], ["--format"]),
    "frames-missing-pose-column": (_drop_pose_column, [], ["frames.csv", "LKnee.rx"]),
    "summary-without-fps": (_without_fps, [], ["summary.json", "--fps"]),
    "fps-zero": (lambda run: None, ["--fps", "0"], ["--fps"]),
    "summary-not-json": (lambda run: (run / "summary.json").write_text("{"), [], ["summary.json", "JSON"]),
    "c3d-not-installed": (None, ["--format", "c3d"], ["c3d", "pip install 'mmocap[export]'"]),
    "units-unknown": (lambda run: None, ["--units", "km"], ["--units", "km"]),
    "names-unknown": (lambda run: None, ["--names", "vicon"], ["--names", "vicon"]),
    "frame-unknown": (lambda run: None, ["--frame", "lab"], ["--frame", "lab"]),
    "summary-bad-up": (
        lambda run: _edit_config(run, lambda config: config["dataset"].update(up="up")),
        ["--frame", "calibration"],
        ["summary.json", "dataset.up"],
    ),
}


@pytest.mark.parametrize("case", list(BAD_EXPORTS))
def test_bad_export_input_is_one_clear_line(case, tmp_path, poses, capsys, monkeypatch):
    (tmp_path / "run").mkdir()
    run = write_run(tmp_path / "run", poses[:2])
    damage, extra, culprits = BAD_EXPORTS[case]
    if damage is None:  # c3d not installed: import c3d raises ImportError
        monkeypatch.setitem(sys.modules, "c3d", None)
    else:
        damage(run)
    code = run_cli("export", run, *extra)
    captured = capsys.readouterr()
    assert_clean_error(Outcome(["export", str(run), *extra], code, captured.out, captured.err), *culprits)
    assert not (run / "export").exists() or not any((run / "export").iterdir())


def test_a_tracking_run_writes_its_exports(tiny_sequence, tmp_path):
    from mmocap.pipeline import run

    cfg = compose(
        [
            "dataset=folder",
            f"dataset.root={tiny_sequence}",
            "evaluator=numpy",
            "body.vertices=1000",
            "tracking.evaluations=30",
            "tracking.frames=1",
            "overlays=0",
            "progress=false",
            "foreground_cache=null",
            "export=[csv,bvh,trc]",
            "export_options.units=m",
            "export_options.names=pose2sim",
        ]
    )
    summary = run(cfg, tmp_path)
    assert summary["fps"] == json.loads((tiny_sequence / "sequence.json").read_text())["fps"]
    assert sorted(p.name for p in (tmp_path / "export").iterdir()) == [
        "joints_mm.csv",
        "markers_mm.csv",
        "motion.bvh",
        "motion.trc",
        "pose.csv",
    ]
    header, names, *_ = parse_trc(tmp_path / "export" / "motion.trc")
    assert (header["Units"], names[-1]) == ("m", "Hip")
    # the same files as an export of the finished run, with the run's export options
    again = export_run(tmp_path, ["csv", "bvh", "trc"], out_dir=tmp_path / "again")
    for path in again:
        assert path.read_text() == (tmp_path / "export" / path.name).read_text()


def test_a_run_starting_again_removes_the_exports_of_the_one_before(tmp_path):
    """A run folder without a record is cleared before a run: its old exports go too, a file of
    the user's stays."""
    from mmocap.pipeline import clear_outputs

    folder = tmp_path / "export"
    folder.mkdir()
    for name in ("motion.trc", "pose.csv", ".motion.bvh.0123456789ab.tmp", "notes.txt"):
        (folder / name).write_text("x")
    clear_outputs(tmp_path)
    assert [p.name for p in folder.iterdir()] == ["notes.txt"]


# --- the round trip to Pose2Sim, OpenSim and a lab's own frame ---


@pytest.fixture(scope="module")
def standing(body) -> np.ndarray:
    """(10, 51) poses of a person standing at the rest pose, every rotation jittered by 0.05
    rad: what Pose2Sim's height estimate measures (it keeps the frames with straight legs)."""
    X = np.tile(body.rest_pose(), (10, 1))
    X[:, 3:] += np.random.default_rng(3).normal(0.0, 0.05, (10, 48))
    return X


@pytest.fixture(scope="module")
def pose2sim_wheel(tmp_path_factory) -> Path:
    """Pose2Sim's wheel, downloaded from the package index as ``mmocap pose2sim-demo`` gets it
    (pip's cache keeps it for the next run); skipped where the index cannot be reached."""
    folder = tmp_path_factory.mktemp("pose2sim")
    command = [sys.executable, "-m", "pip", "download", "--no-deps", "--quiet", POSE2SIM_WHEEL, "-d", str(folder)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    wheels = sorted(folder.glob("pose2sim-*.whl"))
    if done.returncode != 0 or not wheels:
        pytest.skip(f"cannot download {POSE2SIM_WHEEL} from the package index: {done.stderr.strip()[-300:]}")
    return wheels[0]


@pytest.fixture(scope="module")
def pose2sim(pose2sim_wheel) -> dict:
    """Pose2Sim's own functions, read from Pose2Sim/common.py in its wheel and run as they are
    (nothing of Pose2Sim is kept in this repository): the module's function definitions and
    its constant tables (``angle_dict``, which the height estimate uses), in a namespace
    holding the modules that ``read_trc`` and ``compute_height`` call, numpy, pandas and
    logging. The module's other top-level statements, its imports of matplotlib (opening a Qt
    figure), rtoml, OpenCV, c3d and anytree and the lookup of Pose2Sim's installed version,
    are left out: neither function uses them, and none of them is installed here."""
    source = zipfile.ZipFile(pose2sim_wheel).read("Pose2Sim/common.py").decode()

    def kept(node) -> bool:
        if isinstance(node, ast.FunctionDef):
            return True
        if not isinstance(node, ast.Assign):
            return False
        try:
            ast.literal_eval(node.value)
        except ValueError:
            return False
        return True

    module = ast.Module([node for node in ast.parse(source).body if kept(node)], type_ignores=[])
    namespace = {"np": np, "pd": pd, "logging": logging, "__name__": "Pose2Sim.common"}
    exec(compile(module, "Pose2Sim/common.py", "exec"), namespace)  # Pose2Sim's code, as it ships
    return namespace


def pose2sim_halpe26_markers(wheel: Path) -> list[str]:
    """The marker names of Pose2Sim's OpenSim marker set for HALPE_26, from its wheel."""
    xml = zipfile.ZipFile(wheel).read("Pose2Sim/OpenSim_Setup/Markers_Halpe26.xml")
    return [marker.get("name") for marker in ET.fromstring(xml).iter("Marker")]


def test_trc_in_metres_holds_the_same_points(tmp_path, body, poses):
    export_motion(tmp_path / "mm", ["trc"], body, poses, FPS)
    export_motion(tmp_path / "m", ["trc"], body, poses, FPS, options=ExportOptions(units="m"))
    header_mm, names_mm, data_mm, *_ = parse_trc(tmp_path / "mm" / "motion.trc")
    header_m, names_m, data_m, *_ = parse_trc(tmp_path / "m" / "motion.trc")
    assert header_m == {**header_mm, "Units": "m"}
    assert names_m == names_mm
    np.testing.assert_allclose(data_m * 1000.0, data_mm, atol=1e-3, rtol=0)


def test_pose2sim_names_rename_the_head_and_add_the_hip(tmp_path, body, poses):
    export_motion(tmp_path, ["trc", "c3d"], body, poses, FPS, options=ExportOptions(names="pose2sim"))
    _, names, data, *_ = parse_trc(tmp_path / "motion.trc")
    expected = [POSE2SIM_NAMES.get(n, n) for n in [*body.marker_names, *skeleton.JOINTS]] + ["Hip"]
    assert names == expected
    assert names[body.marker_names.index("head")] == "Head"
    joints = body.joint_positions(poses)
    hip = (joints[:, skeleton.JOINTS.index("LHip")] + joints[:, skeleton.JOINTS.index("RHip")]) / 2
    np.testing.assert_allclose(data[:, -1], hip, atol=1e-3, rtol=0)
    points = np.concatenate([body.markers(poses), joints], axis=1)
    np.testing.assert_allclose(data[:, :-1], points, atol=1e-3, rtol=0)
    assert ezc3d.c3d(str(tmp_path / "motion.c3d"))["parameters"]["POINT"]["LABELS"]["value"] == expected


def test_pose2sim_names_match_its_halpe26_marker_set(pose2sim_wheel, body):
    halpe26 = pose2sim_halpe26_markers(pose2sim_wheel)
    assert len(halpe26) == 22
    mmocap_names = [*body.marker_names, *skeleton.JOINTS]
    pose2sim_names = [*(POSE2SIM_NAMES.get(n, n) for n in mmocap_names), "Hip"]
    assert len(set(mmocap_names) & set(halpe26)) == 13
    assert len(set(pose2sim_names) & set(halpe26)) == 15
    assert sorted(set(halpe26) - set(pose2sim_names)) == sorted(
        ["Nose", "LBigToe", "LSmallToe", "LHeel", "RBigToe", "RSmallToe", "RHeel"]
    )


def test_pose2sim_reads_the_trc_in_metres_and_estimates_the_height(tmp_path, pose2sim, body, standing):
    """Pose2Sim's read_trc gives the points in metres, and its compute_height (10 cm from heel
    to ankle, as mmocap has no heel; shank, thigh, hip to shoulder, and 1.008 times mid-shoulder
    to Head) gives 1.82 m for the 1.78 m body: its estimate, not a unit off. On the mm files it
    gives 1725 (Pose2Sim's names) and 1769 (mmocap's), and in metres with mmocap's names (no
    Head, no Hip) it falls back on the legs' length / 0.485, 1.98 m."""
    height_m = body.subject.height_mm / 1000.0
    estimates = {}
    for units, names in (("m", "pose2sim"), ("mm", "pose2sim"), ("m", "mmocap"), ("mm", "mmocap")):
        folder = tmp_path / f"{units}-{names}"
        export_motion(folder, ["trc"], body, standing, FPS, options=ExportOptions(units=units, names=names))
        coordinates, frames, times, markers, _ = pose2sim["read_trc"](str(folder / "motion.trc"))
        points, labels = export.named_points(body, standing, names)
        assert markers == labels
        assert list(frames) == list(range(1, len(standing) + 1))
        np.testing.assert_allclose(times, np.arange(len(standing)) / FPS, atol=1e-6)
        scale = 1000.0 if units == "m" else 1.0
        np.testing.assert_allclose(
            coordinates.to_numpy().reshape(points.shape), points / scale, atol=1e-6 * 1000 / scale
        )
        estimates[units, names] = pose2sim["compute_height"](coordinates)
    assert abs(estimates["m", "pose2sim"] - height_m) < 0.03 * height_m
    for names in NAMINGS:  # mm read as metres: about a thousand times off
        assert estimates["mm", names] > 500 * height_m
    assert abs(estimates["m", "pose2sim"] - height_m) < abs(estimates["m", "mmocap"] - height_m)


def test_calibration_frame_turns_every_point_back(tmp_path, body, poses):
    """A recording tracked with dataset.up=+z: with frame=calibration every point, and the BVH,
    is in the calibration's z-up world, as the lab's own marker data are."""
    (tmp_path / "world").mkdir()
    world = write_run(tmp_path / "world", poses, overrides=["dataset=recording", "dataset.root=/lab", "dataset.up=+z"])
    lab = tmp_path / "lab"
    export_run(world, FORMATS, out_dir=lab, frame="calibration")
    export_run(world, FORMATS)
    turn = UP_AXES["+z"].T  # mmocap's world -> the calibration's
    _, _, w, *_ = parse_trc(world / "export" / "motion.trc")
    _, _, lab_trc, *_ = parse_trc(lab / "motion.trc")
    # the lab's z is mmocap's y (up), its y mmocap's -z, its x mmocap's x
    np.testing.assert_allclose(lab_trc, np.stack([w[..., 0], -w[..., 2], w[..., 1]], axis=-1), atol=1e-5, rtol=0)
    point = ezc3d.c3d(str(lab / "motion.c3d"))["parameters"]["POINT"]
    np.testing.assert_allclose(
        ezc3d.c3d(str(lab / "motion.c3d"))["data"]["points"][:3].transpose(2, 1, 0), lab_trc, atol=1e-3
    )
    assert (point["X_SCREEN"]["value"], point["Y_SCREEN"]["value"]) == (["+X"], ["+Z"])
    markers = read_markers(lab / "markers_mm.csv", len(poses), list(body.marker_names))
    np.testing.assert_allclose(markers, body.markers(poses) @ turn.T, atol=1e-3, rtol=0)
    joints = pd.read_csv(lab / "joints_mm.csv")[["x_mm", "y_mm", "z_mm"]].to_numpy().reshape(len(poses), 16, 3)
    np.testing.assert_allclose(joints, body.joint_positions(poses) @ turn.T, atol=1e-3, rtol=0)
    assert (lab / "pose.csv").read_text() == (world / "export" / "pose.csv").read_text()  # the model's parameters
    root = bvhio.readAsHierarchy(str(lab / "motion.bvh"))
    expected = body.joint_positions(poses) @ turn.T / 1000.0
    for frame in range(len(poses)):
        root.loadPose(frame, recursive=True)
        got = {joint.Name: np.array(joint.PositionWorld) for joint, _, _ in root.layout()}
        np.testing.assert_allclose([got[n] for n in skeleton.JOINTS], expected[frame], atol=1e-4, rtol=0)


def test_calibration_frame_of_a_y_up_dataset_is_its_world(tmp_path, exported):
    """A synthetic sequence has no dataset.up: it was tracked in its calibration's world."""
    run, _ = exported
    export_run(run, ["trc", "bvh"], out_dir=tmp_path, frame="calibration")
    for name in ("motion.trc", "motion.bvh"):
        assert (tmp_path / name).read_text() == (run / "export" / name).read_text()


def test_export_keeps_the_run_s_options_unless_told(tmp_path, poses):
    run = write_run(tmp_path, poses[:2], overrides=["export_options.units=m", "export_options.names=pose2sim"])
    export_run(run, ["trc"])
    header, names, *_ = parse_trc(run / "export" / "motion.trc")
    assert (header["Units"], names[-1]) == ("m", "Hip")
    export_run(run, ["trc"], out_dir=tmp_path / "mm", units="mm")
    header, names, *_ = parse_trc(tmp_path / "mm" / "motion.trc")
    assert (header["Units"], names[-1]) == ("mm", "Hip")


def test_cli_export_options(exported, tmp_path):
    run, _ = exported
    args = ["--format", "trc", "--out", tmp_path, "--units", "m", "--names", "pose2sim", "--frame", "calibration"]
    done = mmocap("export", run, *args, timeout=120)
    assert done.returncode == 0, done.stderr
    header, names, *_ = parse_trc(tmp_path / "motion.trc")
    assert (header["Units"], names[-1]) == ("m", "Hip")


def test_bad_export_options_are_config_errors():
    for key, value, choices in (
        ("units", "km", "mm, m"),
        ("names", "vicon", "mmocap, pose2sim"),
        ("frame", "lab", "world, calibration"),
    ):
        with pytest.raises(InstantiationException) as raised:
            check_config(compose([f"export_options.{key}={value}"]))
        assert isinstance(raised.value.__cause__, ConfigError)
        assert str(raised.value.__cause__) == f"export_options.{key} must be one of {choices}, got {value!r}"


# --- frames.csv cut short or damaged (Hypothesis: tests/helpers.py damages) ------------------

#: three frames' poses (mm, rad) written the way FrameLog writes them (6 decimals)
SMALL_POSES = np.round(np.random.default_rng(9).uniform(-3, 3, (3, 51)), 6)


@pytest.fixture(scope="module")
def frames_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("frames") / "frames.csv"
    log = FrameLog(path)
    for frame, pose in enumerate(SMALL_POSES):
        log.write(frame, 10.0, 0.1, 100, 0.5, pose)
    log.close()
    return path, path.read_bytes()


@settings(max_examples=60)
@given(data=st.data())
def test_a_cut_frames_file_is_refused_or_read_as_its_whole_rows(frames_file, data):
    """A cut inside a row is refused; a cut at a row's end gives the poses of the frames kept."""
    path, whole = frames_file
    damage = data.draw(damages(whole))
    outcome = read_damaged(read_poses, path, damage, whole)
    if damage.kind == "cut" and outcome is not None:
        assert whole[: damage.offset].endswith(b"\n"), f"{damage}: a row cut inside was read"
        np.testing.assert_array_equal(outcome[0], SMALL_POSES[: damage.whole_lines(whole) - 1])
