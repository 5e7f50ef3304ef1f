"""The held-out camera: a run tracked without a camera is measured against that camera's own
foreground and landmarks. On synthetic data the agreement is high and a wrong body lowers it;
on Pose2Sim's real demo (fetched from its wheel, a few frames at a quarter of its resolution)
the whole path of `make real-demo` runs: no plate, Qualisys calibration, codec padding."""

import json

import numpy as np
import pandas as pd
import pytest

from mmocap.errors import DataError
from mmocap.report.held_out import JOINT_GROUPS, held_out_frames, runs_table, side_by_side, summary_table
from mmocap.stages import segmentation
from mmocap.stages.segmentation import JOINT_LANDMARKS
from tests.helpers import QUICK_START, overrides, run_cli

pytestmark = pytest.mark.skipif(not segmentation.available(), reason="the segment extra is not installed")


def track(out, *extra) -> dict:
    code = run_cli(
        "track",
        "body.vertices=1000",
        "overlays=0",
        "progress=false",
        f"foreground_cache={out.parent / 'cache'}",
        f"hydra.run.dir={out}",
        *extra,
    )
    assert code == 0
    return json.loads((out / "summary.json").read_text())


@pytest.fixture(scope="module")
def synthetic_runs(tmp_path_factory):
    """A 640x480 synthetic sequence tracked without C2, from its first pose, by person
    segmentation (which finds landmarks): once with the true body, once with one far too tall."""
    base = tmp_path_factory.mktemp("held_out")
    sequence = overrides(
        base / "data",
        **{"dataset.cameras": "[C1,C3,BW1]", "dataset.all_cameras": "[C1,C2,C3,BW1]"},
        **{"dataset.width": 640, "dataset.height": 480, "foreground.method": "segmentation"},
    )
    right = track(base / "right", *sequence)
    track(base / "tall", *sequence, "body.height_mm=2100", "body.girth=1.4")
    return base, right


def test_the_held_out_camera_agrees_with_a_good_track_and_less_with_a_wrong_body(synthetic_runs):
    base, summary = synthetic_runs
    assert summary["cameras"] == ["C1", "C3", "BW1"]
    right, tall = held_out_frames(base / "right", "C2"), held_out_frames(base / "tall", "C2")
    assert list(right.columns) == ["frame", "iou", "person_height_px", *(f"{j}_px" for j in JOINT_LANDMARKS)]
    assert len(right) == 2
    assert right["iou"].mean() > 0.6
    assert tall["iou"].mean() < right["iou"].mean() - 0.1
    table = summary_table(right, "C2")
    assert list(table["measure"])[: 1 + len(JOINT_GROUPS)] == [
        "silhouette IoU",
        *(f"{group} (px)" for group in JOINT_GROUPS),
    ]
    joints = table.set_index("measure").loc["all joints (% of person height)", "mean (C2)"]
    both = side_by_side(
        {"right": summary_table(right, "C2, right"), "tall": summary_table(tall, "C2, tall")}, "C2"
    ).set_index("measure")
    assert both.loc["silhouette IoU", "mean (C2, right)"] == pytest.approx(right["iou"].mean())
    assert both.loc["silhouette IoU", "mean (C2, tall)"] < both.loc["silhouette IoU", "mean (C2, right)"]
    assert 0 < joints < 15  # landmarks are not joint centres: a floor above 0, far below a lost track
    with pytest.raises(DataError, match="camera C1: the run .* was tracked with it"):
        held_out_frames(base / "right", "C1")


def test_the_runs_table_lists_times_fitness_and_body(synthetic_runs):
    base, summary = synthetic_runs
    table = runs_table([base / "right", base / "tall"])
    assert list(table["run"]) == ["right", "tall"]
    assert table.loc[0, "body height (mm)"] == pytest.approx(summary["body"]["height_mm"])
    assert table.loc[0, "mean fitness"] < table.loc[1, "mean fitness"]


def test_pose2sim_real_demo_is_read_as_it_ships_and_tracked_without_a_plate(tmp_path, capsys):
    """The fast version of `make real-demo`: 2 frames at a quarter of 1080x1920."""
    assert run_cli("pose2sim-demo", tmp_path) == 0
    root = tmp_path / "Demo_SinglePerson"
    assert sorted(p.name for p in (root / "videos").iterdir()) == [f"cam0{k}.mp4" for k in range(1, 5)]
    capsys.readouterr()
    assert run_cli("check-recording", root, "dataset.scale=0.25") == 0
    report = capsys.readouterr()
    assert "foreground: person segmentation (MediaPipe Pose) (auto: no empty-scene plate" in report.out
    assert "keypoints in the fitness: detector (person segmentation finds MediaPipe's landmarks)" in report.out
    assert "translations in mm" in report.out
    # the only warnings: cam01's and cam02's videos lack the codec's 8 padding columns
    warned = [line for line in report.err.splitlines() if line.startswith("mmocap: warning:")]
    assert len(warned) == 2
    assert all("is 1080x1920, its calibration says 1088x1920" in w for w in warned)
    setup = ["dataset.scale=0.25", "tracking.frames=2"]
    summary = track(
        tmp_path / "held-out",
        "dataset=recording",
        f"dataset.root={root}",
        "tracking.evaluations=300",
        *QUICK_START,
        *setup,
        "dataset.cameras=[cam01,cam02,cam03]",
    )
    assert summary["keypoints"]["source"] == "segmentation"  # no plate: the segmenter's landmarks
    assert summary["start"]["method"] == "keypoints"  # and the start from them
    assert 1500 < summary["body"]["height_mm"] < 1950
    assert run_cli("held-out", tmp_path / "held-out", "--camera", "cam04", "--no-progress") == 0
    frames = pd.read_csv(tmp_path / "held-out" / "held_out_cam04.csv")
    assert len(frames) == 2
    assert np.nanmean(frames["iou"]) > 0.4
