"""Motion-file exports of a finished run, each read back by an independent reader: TRC by a
plain parser written here, C3D by ezc3d, BVH by bvhio (its own forward kinematics), CSV by
pandas and by mmocap's ground-truth reader."""

from __future__ import annotations

import errno
import json
import math
import sys
from pathlib import Path

import bvhio
import ezc3d
import numpy as np
import pandas as pd
import pytest
from omegaconf import OmegaConf

from mmocap.body import skeleton
from mmocap.body.model import BodyModel
from mmocap.config import compose
from mmocap.data.sequence import read_markers
from mmocap.errors import ConfigError, DataError
from mmocap.io import WriteError
from mmocap.preflight import check_config
from mmocap.stages.accuracy import FrameLog
from mmocap.writers import export
from mmocap.writers.export import FORMATS, export_motion, export_run, read_poses, write_c3d, write_trc
from tests.helpers import Outcome, assert_clean_error, mmocap, run_cli

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


def write_run(folder, poses, *, fps: float | None = FPS, body_facts: dict | None = None):
    """A finished run folder as a tracking run leaves it: frames.csv (by FrameLog) and a
    summary.json with the composed config (body.vertices=1000)."""
    log = FrameLog(folder / "frames.csv")
    for frame, pose in enumerate(poses):
        log.write(frame, 1.0, 0.5, 60, 0.01, pose)
    log.close()
    summary = {
        **json.loads(SUMMARY_EXAMPLE.read_text()),
        "config": OmegaConf.to_container(compose(["body.vertices=1000"]), resolve=True),
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
    write_trc(tmp_path / "m.trc", points, ["a", "b"], 100.0)
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


def test_c3d_missing_point_round_trips_as_nan(tmp_path):
    points = np.array([[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], [[7.0, 8.0, 9.0], [np.nan, 0.0, 1.0]]])
    write_c3d(tmp_path / "m.c3d", points, ["a", "b"], 120.0)
    got = ezc3d.c3d(str(tmp_path / "m.c3d"))["data"]["points"][:3].transpose(2, 1, 0)
    expected = points.copy()
    expected[1, 1] = np.nan  # a point with any coordinate missing is invalid as a whole
    np.testing.assert_array_equal(got, expected)


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
            "export=[csv,bvh]",
        ]
    )
    summary = run(cfg, tmp_path)
    assert summary["fps"] == json.loads((tiny_sequence / "sequence.json").read_text())["fps"]
    assert sorted(p.name for p in (tmp_path / "export").iterdir()) == [
        "joints_mm.csv",
        "markers_mm.csv",
        "motion.bvh",
        "pose.csv",
    ]
    # the same files as an export of the finished run
    again = export_run(tmp_path, ["csv", "bvh"], out_dir=tmp_path / "again")
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
