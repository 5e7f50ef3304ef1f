"""Person segmentation (MediaPipe Pose): it finds the rendered person without a plate, with
landmarks where the body's joints are; the foreground stage caches both; without MediaPipe the
method is refused with the install line."""

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from mmocap.data.recording.reader import RecordingDataset, write_recording
from mmocap.data.sequence import Sequence
from mmocap.data.synthetic import generate
from mmocap.errors import ConfigError
from mmocap.stages import segmentation
from mmocap.stages.foreground import Foreground, GivenMask, choose_method
from mmocap.stages.segmentation import LANDMARK_NAMES, PersonSegmenter
from tests.helpers import TINY

pytestmark = pytest.mark.skipif(not segmentation.available(), reason="the segment extra is not installed")


def iou(a, b) -> float:
    return float((a & b).sum() / (a | b).sum())


@pytest.fixture(scope="module")
def sequence(tmp_path_factory) -> Sequence:
    """The tiny sequence at 640x480, 2 frames: at 320x240 the detector misses the greyscale
    camera's person (about 60 px tall); HumanEva-I's cameras are 640x480."""
    settings = {**TINY, "width": 640, "height": 480, "frames": 2, "background_frames": 2}
    return Sequence.open(generate(tmp_path_factory.mktemp("data") / "S1_walking", progress=False, **settings))


def test_the_person_is_found_without_a_plate_and_the_landmarks_lie_on_the_body(sequence):
    segmenter = PersonSegmenter()
    for cam, image in zip(sequence.cameras, sequence.images(1)):
        mask, landmarks = segmenter.find_person(image, name=cam.name)
        truth = sequence.silhouette(1, cam)
        assert mask.shape == truth.shape
        assert iou(mask, truth) > 0.8, cam.name
        assert landmarks.shape == (len(LANDMARK_NAMES), 3)
        assert landmarks.dtype == np.float32
        # the hips and shoulders, seen by the model, fall on the rendered body
        for name in ("left_shoulder", "right_shoulder", "left_hip", "right_hip"):
            u, v, visibility = landmarks[LANDMARK_NAMES.index(name)]
            assert 0 <= visibility <= 1
            near = truth[max(int(v) - 3, 0) : int(v) + 4, max(int(u) - 3, 0) : int(u) + 4]
            assert near.any(), f"{cam.name} {name} at ({u:.0f}, {v:.0f}) is off the body"


def test_an_empty_scene_gives_an_empty_mask_and_no_landmarks(sequence):
    mask, landmarks = PersonSegmenter().find_person(sequence.background(sequence.cameras[0])[0])
    assert not mask.any()
    assert landmarks is None


def test_a_second_run_reads_masks_and_landmarks_from_the_cache(sequence, tmp_path, monkeypatch):
    first = Foreground(sequence, PersonSegmenter, cache_dir=tmp_path)
    masks, landmarks = first.detections(1)
    assert all(points is not None for points in landmarks)

    def refuse(*args, **kwargs):
        raise AssertionError("segmented again instead of read from the cache")

    monkeypatch.setattr(PersonSegmenter, "find_person", refuse)
    second = Foreground(sequence, PersonSegmenter, cache_dir=tmp_path)
    again, again_landmarks = second.detections(1)
    assert second.cache.hits == 1
    for a, b in zip(masks, again):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(landmarks, again_landmarks):
        np.testing.assert_array_equal(a, b)


@pytest.fixture(scope="module")
def plateless(sequence, tmp_path_factory) -> Path:
    """The tiny sequence as a recording without its empty-scene plate."""
    root = write_recording(sequence, tmp_path_factory.mktemp("plateless") / "rec", progress=False)
    shutil.rmtree(root / "background")
    return root


def test_auto_chooses_segmentation_without_a_plate_and_says_why(plateless):
    opened = RecordingDataset(str(plateless)).open(progress=False)
    make, reason = choose_method(opened, "auto", None, PersonSegmenter, GivenMask)
    assert make is PersonSegmenter
    assert "person segmentation" in reason
    assert "no empty-scene plate" in reason


def test_without_mediapipe_segmentation_is_refused_with_the_install_line(plateless, monkeypatch):
    monkeypatch.setattr(segmentation, "available", lambda: False)
    opened = RecordingDataset(str(plateless)).open(progress=False)
    with pytest.raises(ConfigError, match=re.escape(segmentation.INSTALL)):
        choose_method(opened, "auto", None, PersonSegmenter, GivenMask)
    with pytest.raises(ConfigError, match="not installed"):
        PersonSegmenter()


def test_the_makefile_installs_the_mediapipe_of_the_install_line():
    makefile = (Path(__file__).parents[2] / "Makefile").read_text()
    pinned = re.search(r"^MEDIAPIPE\s*:=\s*(\S+)", makefile, re.M).group(1)
    assert f"--no-deps {pinned}" in segmentation.INSTALL
