"""The keypoint stage: where keypoints come from, their mapping onto the model's points,
and the frames it hands the evaluators."""

from types import SimpleNamespace

import numpy as np
import pytest

from mmocap.data.skeletons import HALPE_26, MAPPINGS, MEDIAPIPE_33
from mmocap.errors import ConfigError
from mmocap.stages.keypoints import KeypointSource, SkeletonMap


def sequence(has_keypoints: bool, cameras=("C1", "C2")):
    cams = [SimpleNamespace(name=name, dist=np.zeros(5)) for name in cameras]
    return SimpleNamespace(has_keypoints=has_keypoints, root="/data/seq", cameras=cams)


def foreground(finds_landmarks: bool):
    return SimpleNamespace(finds_landmarks=finds_landmarks)


@pytest.mark.parametrize(
    ("source", "files", "landmarks", "chosen"),
    [
        ("auto", True, True, "files"),  # files first
        ("auto", False, True, "detector"),  # then person segmentation's landmarks
        ("auto", False, False, "none"),  # then silhouettes only
        ("none", True, True, "none"),
        ("detector", False, False, "detector"),
    ],
)
def test_auto_takes_files_then_the_segmentations_landmarks_then_none(source, files, landmarks, chosen):
    assert KeypointSource(source).choose(sequence(files), foreground(landmarks))[0] == chosen


def test_files_asked_for_but_absent_and_an_unknown_source_are_refused():
    with pytest.raises(ConfigError, match="keypoints.source=files, but /data/seq has no keypoint files"):
        KeypointSource("files").choose(sequence(False), foreground(False))
    with pytest.raises(ConfigError, match="keypoints.source must be one of"):
        KeypointSource("openpose")
    with pytest.raises(ConfigError, match="unknown keypoint skeleton 'BODY_135'"):
        KeypointSource(skeleton="BODY_135")


def test_a_skeletons_map_keeps_the_mapped_rows_in_the_mappings_order():
    halpe = SkeletonMap.of("HALPE_26")
    assert halpe.points[halpe.rows.tolist().index(HALPE_26.index("Hip"))] == "Root"
    assert [HALPE_26[r] for r in halpe.rows] == list(MAPPINGS["HALPE_26"])
    mediapipe = SkeletonMap.of("MEDIAPIPE_33")
    hip = mediapipe.points.index("LHip")
    assert MEDIAPIPE_33[mediapipe.rows[hip]] == "left_hip"
    np.testing.assert_array_equal(mediapipe.offsets_mm[hip], MAPPINGS["MEDIAPIPE_33"]["left_hip"][1])


def test_segmentation_landmarks_become_keypoints_and_a_camera_without_any_counts_nothing():
    seq = sequence(False)
    stream = KeypointSource().open(seq, SimpleNamespace(finds_landmarks=True, method="segmentation"))
    landmarks = np.zeros((33, 3))
    landmarks[MEDIAPIPE_33.index("left_hip")] = (100.0, 200.0, 0.9)
    landmarks[MEDIAPIPE_33.index("nose")] = (50.0, 60.0, 0.0)  # not visible
    frame = stream.frame(0, [landmarks, None])
    hip = frame.points.index("LHip")
    np.testing.assert_array_equal(frame.observed[0, hip], (100.0, 200.0, 0.9))
    assert not frame.observed[1].any()  # nobody found in C2
    assert frame.observed[0, frame.points.index("Nose")].tolist() == [0.0, 0.0, 0.0]
    stream.frame(0, [landmarks, None])  # the start reads frame 0 too: counted once
    assert stream.summary()["seen"]["LHip"] == 0.5  # one of two cameras, one frame
    assert stream.summary()["source"] == "segmentation"
