"""A run's pictures: a video per camera comparing foreground and model, and the skeleton."""
import json

import cv2
import numpy as np
import pytest

from mmocap.analysis.figures import COMPARISON_COLOURS
from mmocap.video import VideoReader, count_frames
from tests.conftest import run_cli


@pytest.fixture(scope="module")
def run_folder(tiny_sequence, tmp_path_factory):
    out = tmp_path_factory.mktemp("videos") / "run"
    code = run_cli("track", "dataset=folder", f"dataset.root={tiny_sequence}", "evaluator=numpy",
                   "body.vertices=1000", "tracking.evaluations=60", "overlays=0", "progress=false",
                   "foreground_cache=null", "video=true", f"hydra.run.dir={out}")
    assert code == 0
    return out


def test_every_camera_has_a_video_of_every_tracked_frame_at_its_size(run_folder):
    summary = json.loads((run_folder / "summary.json").read_text())
    for camera in summary["cameras"]:
        path = run_folder / "videos" / f"{camera}.mp4"
        assert count_frames(path) == summary["frames"] == 4
        assert VideoReader(path).read(3).shape == (240, 320, 3)


def test_the_video_shows_foreground_model_and_overlap_in_their_colours(run_folder):
    frame = VideoReader(run_folder / "videos" / "C1.mp4").read(0).astype(int)
    for name, colour in COMPARISON_COLOURS.items():
        # a tinted pixel is half the colour plus half the image: its dominant channel is the colour's
        channel = int(np.argmax(colour))
        others = [c for c in range(3) if c != channel]
        dominant = (frame[..., channel] - frame[..., others].max(axis=-1)) > 60
        assert np.count_nonzero(dominant) > 50, name


def test_the_skeleton_pictures_are_written(run_folder):
    assert cv2.imread(str(run_folder / "skeleton.png")) is not None
    assert count_frames(run_folder / "skeleton.mp4") == 4


def test_a_rerun_without_video_removes_the_old_ones(run_folder, tiny_sequence):
    (run_folder / "records").rename(run_folder / "old-records")  # the run is not skipped
    code = run_cli("track", "dataset=folder", f"dataset.root={tiny_sequence}", "evaluator=numpy",
                   "body.vertices=1000", "tracking.evaluations=60", "overlays=0", "progress=false",
                   "foreground_cache=null", f"hydra.run.dir={run_folder}")
    assert code == 0
    assert not list((run_folder / "videos").glob("*.mp4")) and not (run_folder / "skeleton.png").exists()
