"""The command line end to end: tracking a tiny sequence, and clear errors for bad input."""

import json
import shutil
from importlib.metadata import version

import cv2
import numpy as np
import pytest

from tests.helpers import mmocap_in_process as mmocap
from tests.helpers import overrides


@pytest.fixture
def data_root(tiny_sequence, tmp_path):
    """A private copy of the tiny sequence that a test may damage."""
    root = tmp_path / "data"
    shutil.copytree(tiny_sequence, root / "S1_walking")
    return root


def test_version_is_the_installed_distribution_s(tmp_path):
    out = mmocap("--version", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout == f"mmocap {version('mmocap')}\n"


def test_list_shows_builtin_plugins(tmp_path):
    out = mmocap("list", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    for name in ("cmaes", "numpy", "naive"):
        assert name in out.stdout
    assert "mmocap.optimizers" in out.stdout
    assert "mmocap.evaluators" in out.stdout


def test_track_tiny_sequence(data_root, tmp_path):
    run_dir = tmp_path / "run"
    out = mmocap(*overrides(data_root), f"hydra.run.dir={run_dir}", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "mean marker error" in out.stdout
    summary = json.loads((run_dir / "summary.json").read_text())
    for key in (
        "mean_marker_error_mm",
        "frames",
        "evaluations_per_frame",
        "seconds_per_frame",
        "optimizer",
        "strategy",
        "dof",
        "backend",
    ):
        assert key in summary
    assert summary["frames"] == 2
    assert summary["dof"] == 39
    assert summary["optimizer"] == "cmaes"
    assert summary["evaluations_used"] <= 2 * 300
    # started from the true first pose, with a small budget, at 320x240
    assert summary["mean_marker_error_mm"] < 30  # measured: 12.5 mm
    lines = (run_dir / "frames.csv").read_text().splitlines()
    assert len(lines) == 3
    assert (run_dir / "error_per_frame.png").stat().st_size > 1000
    overlays = list((run_dir / "overlays").glob("*.png"))
    assert len(overlays) == 1
    assert cv2.imread(str(overlays[0])) is not None


BAD_CONFIGS = [
    (["optimizer=nope"], "optimizer/nope"),
    (["optimizer.name=nope"], "unknown optimizer 'nope'"),
    (["evaluator.name=gpu9"], "unknown evaluator 'gpu9'"),
    (["tracking.evaluations=-5"], "tracking.evaluations must be an integer in [2, 100000000], got -5"),
    (["body.dof=30"], "body.dof must be one of"),
    (["tracking.frames=99"], "tracking.frames must be in [1, 4], got 99"),
    (["dataset.cameras=[C1,C4]"], "C4 not in dataset.all_cameras"),
    (["strategy.rotation_radius=0"], "strategy.rotation_radius must be in (0, pi], got 0"),
    (
        ["tracking.evaluations=14"],
        "tracking.evaluations=14 gives the frame 13 evaluations but "
        "optimizer 'cmaes' needs at least 14 for 39 degrees of freedom",
    ),
    (["optimizer.popsize=1"], "optimizer.popsize must be an integer in [2, inf), got 1"),
    (["strategy=hierarchical", "partition.steps=[[Root],[Torso]]"], "unknown joint(s) Torso"),
    (
        [
            "strategy=hierarchical",
            "body.dof=28",
            "partition.steps=[[Root],[BottomSpine,UpperSpine,Neck],[LShoulder,LElbow],[LWrist,RWrist],"
            "[RShoulder,RElbow],[LHip,LKnee,LAnkle],[RHip,RKnee,RAnkle]]",
        ],
        "strategy step 4 (LWrist, RWrist) has no degree of freedom in the 28-DOF body model",
    ),
]


@pytest.mark.parametrize(("extra", "message"), BAD_CONFIGS, ids=[b[0][0] for b in BAD_CONFIGS])
def test_bad_config_gives_one_clear_error(data_root, tmp_path, extra, message):
    out = mmocap(*overrides(data_root), *extra, f"hydra.run.dir={tmp_path / 'run'}", cwd=tmp_path)
    assert out.returncode != 0
    assert message in out.stderr
    assert "Traceback" not in out.stderr


def damage_calibration(root):
    (root / "S1_walking" / "calibration" / "C2.json").write_text('{"K": [1, 2')
    return "C2.json is not valid JSON"


def remove_calibration(root):
    (root / "S1_walking" / "calibration" / "C2.json").unlink()
    return "calibration file not found"


def remove_camera_folder(root):
    shutil.rmtree(root / "S1_walking" / "images" / "BW1")
    return "camera BW1: image folder missing"


def shrink_image(root):
    path = root / "S1_walking" / "images" / "C1" / "000001.png"
    cv2.imwrite(str(path), np.zeros((100, 100, 3), np.uint8))
    return "camera C1: image"


@pytest.mark.parametrize("damage", [damage_calibration, remove_calibration, remove_camera_folder, shrink_image])
def test_bad_data_gives_one_clear_error(data_root, tmp_path, damage):
    message = damage(data_root)
    out = mmocap(*overrides(data_root), f"hydra.run.dir={tmp_path / 'run'}", cwd=tmp_path)
    assert out.returncode == 2
    assert message in out.stderr
    assert "Traceback" not in out.stderr
    if damage is shrink_image:
        assert "100x100, calibration says 320x240" in out.stderr


def test_generate_only_renders(tmp_path):
    out = mmocap(
        "generate",
        f"dataset.root={tmp_path / 'data'}",
        "dataset.frames=2",
        "dataset.width=160",
        "dataset.height=120",
        "dataset.all_cameras=[C1,BW2]",
        "dataset.cameras=[BW2]",
        "dataset.action=gestures",
        "dataset.subject=S3",
        "progress=false",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    assert "sequence ready" in out.stdout
    meta = json.loads((tmp_path / "data" / "S3_gestures" / "sequence.json").read_text())
    assert meta["cameras"] == ["C1", "BW2"]
    assert meta["frames"] == 2


@pytest.mark.slow
def test_demo_scale_tracking_is_accurate(tmp_path):
    """The demo's setting on 20 frames: 640x480, 4 cameras, 39 DOF, 1500 evaluations."""
    run_dir = tmp_path / "run"
    out = mmocap(
        "+experiment=demo",
        "dataset.frames=20",
        f"dataset.root={tmp_path / 'data'}",
        "progress=false",
        f"hydra.run.dir={run_dir}",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["frames"] == 20
    assert summary["mean_marker_error_mm"] < 40
