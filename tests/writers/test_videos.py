"""A run's pictures: a video per camera comparing foreground and model, and the skeleton."""

import functools
import json

import cv2
import numpy as np
import pytest

from mmocap.body.model import BodyModel
from mmocap.data.sequence import Sequence
from mmocap.evaluators.numpy_backend import NumpyEvaluator
from mmocap.stages.background import GaussianBackground
from mmocap.stages.foreground import Foreground
from mmocap.stages.tracking import FrameResult
from mmocap.video import VideoReader, count_frames
from mmocap.writers.overlays import COMPARISON_COLOURS, comparison_overlay
from mmocap.writers.videos import camera_frames, frame_caption, run_video_files, write_run_videos
from tests.helpers import run_cli

#: how far (mm, along x) the pose drawn for frame 1 is moved off the true one, so that the
#: foreground and the model each have pixels the other lacks
SHIFT_MM = 150.0


@pytest.fixture(scope="module")
def scene(tiny_sequence, tmp_path_factory):
    """The tiny sequence's parts built directly, and results for its 4 frames: the true poses,
    frame 1's moved by :data:`SHIFT_MM`, frame 2 without ground truth."""
    sequence = Sequence.open(tiny_sequence)
    body = BodyModel("S1", vertices=1000)
    foreground = Foreground(sequence, functools.partial(GaussianBackground), cache_dir=tmp_path_factory.mktemp("cache"))
    poses = np.load(tiny_sequence / "poses.npy")
    poses[1, 0] += SHIFT_MM
    results = [FrameResult(k, pose, 0.25 + k / 10, 100, 0.1) for k, pose in enumerate(poses)]
    truth = sequence.markers()
    truth[2] = np.nan
    return sequence, foreground, NumpyEvaluator(patch_scale=1.5), body, results, truth


def test_a_camera_frame_tints_foreground_model_and_overlap_where_they_are(scene):
    sequence, foreground, evaluator, body, results, truth = scene
    c = 1  # C2
    images = list(camera_frames(sequence, foreground, evaluator, body, results, truth, c))
    assert len(images) == len(results)
    assert all(image.shape == (240, 320, 3) and image.dtype == np.uint8 for image in images)
    frame = results[1].frame
    drawn = images[1].astype(int)
    mask = foreground.masks(frame)[c]
    evaluator.setup(body, foreground.cameras, foreground.masks(frame))
    model = evaluator.render(results[1].pose, c)
    mx, my = sequence.cameras[c].undistort_maps()
    image = cv2.remap(sequence.images(frame)[c], mx, my, cv2.INTER_LINEAR).astype(int)
    # the pixels the skeleton, markers, text and legend leave alone: white over white, black over black
    nothing = np.zeros((240, 320), bool)
    joints = body.joint_positions(results[1].pose[None])[0]
    over_white, over_black = (
        comparison_overlay(
            np.full((240, 320, 3), value, np.uint8),
            foreground.cameras[c],
            nothing,
            nothing,
            joints,
            truth[frame],
            frame_caption("C2", results[1], body, truth),
        )
        for value in (255, 0)
    )
    undrawn = ((over_white.astype(int) - over_black) == 255).all(axis=-1)
    regions = {
        "foreground only": mask & ~model,
        "model only": model & ~mask,
        "both": mask & model,
        "neither": ~mask & ~model,
    }
    for name, where in regions.items():
        expected = image if name == "neither" else (image + np.array(COMPARISON_COLOURS[name])) / 2
        matching = (np.abs(drawn - expected) <= 1).all(axis=-1)
        assert np.count_nonzero(where & undrawn) > 100, name
        assert np.count_nonzero(matching & where & undrawn) > 0.99 * np.count_nonzero(where & undrawn), name


def test_the_caption_gives_camera_frame_fitness_and_marker_error(scene):
    sequence, _, _, body, results, truth = scene
    camera, fitness, error = frame_caption("C2", results[1], body, truth)
    assert (camera, fitness) == ("C2  frame 1", "fitness 0.3500")
    # every marker moves with the root: the error is the shift
    assert error.startswith("marker error ")
    assert abs(float(error.split()[2]) - SHIFT_MM) < 1.0
    assert frame_caption("C2", results[2], body, truth)[2] == "no ground truth"


def test_the_run_videos_hold_every_result_of_every_camera(scene, tmp_path):
    sequence, foreground, evaluator, body, results, truth = scene
    written = write_run_videos(tmp_path, sequence, foreground, evaluator, body, results[:3], truth)
    assert sorted(written) == sorted(run_video_files(tmp_path))
    for camera in sequence.cameras:
        assert count_frames(tmp_path / "videos" / f"{camera.name}.mp4") == 3
    assert count_frames(tmp_path / "skeleton.mp4") == 3
    assert cv2.imread(str(tmp_path / "skeleton.png")).shape[0] > 100


@pytest.fixture(scope="module")
def run_folder(tiny_sequence, tmp_path_factory):
    out = tmp_path_factory.mktemp("videos") / "run"
    code = run_cli(
        "track",
        "dataset=folder",
        f"dataset.root={tiny_sequence}",
        "evaluator=numpy",
        "body.vertices=1000",
        "tracking.evaluations=60",
        "overlays=0",
        "progress=false",
        "foreground_cache=null",
        "video=true",
        f"hydra.run.dir={out}",
    )
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


def test_a_rerun_without_video_removes_the_old_ones_and_a_stopped_runs_temporaries(run_folder, tiny_sequence):
    (run_folder / "records").rename(run_folder / "old-records")  # the run is not skipped
    # what a run stopped while writing leaves: the encoder's file and atomic_path's temporary
    videos = run_folder / "videos"
    temporaries = [
        videos / ".C1.mp4.0123456789ab.mp4",
        videos / ".C2.mp4.0123456789ab.tmp",
        run_folder / ".skeleton.mp4.0123456789ab.mp4",
    ]
    for path in temporaries:
        path.write_bytes(b"partial")
    code = run_cli(
        "track",
        "dataset=folder",
        f"dataset.root={tiny_sequence}",
        "evaluator=numpy",
        "body.vertices=1000",
        "tracking.evaluations=60",
        "overlays=0",
        "progress=false",
        "foreground_cache=null",
        f"hydra.run.dir={run_folder}",
    )
    assert code == 0
    assert not list(videos.iterdir())
    assert not (run_folder / "skeleton.png").exists()
    assert not (run_folder / "skeleton.mp4").exists()
    assert not any(path.exists() for path in temporaries)
