"""The recording commands end to end: a sequence written as a recording (to-recording), checked
(check-recording) and tracked by the one documented command with no first pose and no body
size given (dataset=recording: the automatic start)."""

import json

import pytest

from tests.helpers import QUICK_START, run_cli


@pytest.fixture(scope="module")
def recording(tiny_sequence, tmp_path_factory):
    out = tmp_path_factory.mktemp("rec") / "walk"
    assert run_cli("to-recording", tiny_sequence, out, "--offsets", "C2=1", "--units", "m", "--no-progress") == 0
    return out


def test_check_recording_reports_cameras_sync_and_the_first_frame(recording, capsys):
    assert run_cli("check-recording", recording, "dataset.offsets={C2:1}", "background.min_area_px=5") == 0
    report = capsys.readouterr().out
    assert "translations in m," in report
    for camera in ("C1", "C2", "BW1"):
        assert f"{camera}: video {recording / 'videos' / camera}.mp4" in report
    assert "(5 frames, 60 fps, offset 1)" in report  # C2: one frame of empty scene first
    assert "frames tracked: 4 from frame 0" in report
    assert "4 of 4 frames have markers" in report
    assert "keypoints: none (no pose/<camera>_json/ folders, no keypoints.csv)" in report
    assert "keypoints in the fitness: none (no keypoint files and no detector run: silhouettes only)" in report
    assert "the silhouettes' rays meet at" in report
    assert "  foreground: background subtraction (HorprasertBackground) on the empty-scene plate (auto: " in report
    assert "first frame: the person's visual hull is" in report


def test_check_recording_warns_of_foreground_the_hull_does_not_explain(recording, capsys):
    """A background model far too sensitive (1 sigma) marks sensor noise everywhere, which no
    other camera confirms: the hull explains little of it, or is no person's height."""
    assert (
        run_cli(
            "check-recording",
            recording,
            "dataset.offsets={C2:1}",
            "background=gaussian",
            "background.threshold=1",
            "background.min_area_px=5",
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "lies inside the person's visual hull" in err or "outside a person's" in err


def test_a_recording_is_tracked_from_nothing_by_the_documented_command(recording, tmp_path):
    out = tmp_path / "run"
    code = run_cli(
        "track",
        "dataset=recording",
        f"dataset.root={recording}",
        "dataset.offsets={C2:1}",
        "evaluator=numpy",
        "body.vertices=1000",
        "tracking.evaluations=60",
        "overlays=1",
        "progress=false",
        "foreground_cache=null",
        "export=[csv]",
        f"hydra.run.dir={out}",
        *QUICK_START,
    )
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["start"]["method"] == "search"
    assert summary["start"]["seconds"] > 0
    assert summary["subject"] == "unknown"
    assert summary["frames"] == summary["frames_scored"] == 4
    assert summary["body"]["height_mm"] == pytest.approx(summary["start"]["hull_height_mm"])  # no steps tried
    assert summary["body"]["girth"] in (1.0, 1.1)
    assert summary["mean_marker_error_mm"] > 0
    assert (out / "export" / "markers_mm.csv").is_file()
