"""Bad 2-D keypoint files and settings, as a user meets them checking a recording
(``mmocap check-recording``, which reads them whole as a run does): one line naming the file,
camera or key, what is wrong and what to do, exit status 2
(:class:`mmocap.data.keypoints.KeypointFiles`)."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mmocap.data.keypoints import KEYPOINTS_CSV, openpose_path, write_openpose_json
from mmocap.data.recording.reader import write_recording
from mmocap.data.sequence import Sequence
from mmocap.data.skeletons import HALPE_26, MAPPINGS, check_mapping
from mmocap.errors import ConfigError
from tests.helpers import TINY_BAD_INPUT, assert_clean_error
from tests.helpers import mmocap_in_process as mmocap

CAMERAS = TINY_BAD_INPUT["cameras"]
FRAMES = TINY_BAD_INPUT["frames"]
#: a HALPE_26 person: every joint seen at a pixel of the 160x120 image
PERSON = np.c_[np.linspace(20, 140, len(HALPE_26)), np.linspace(10, 110, len(HALPE_26)), np.full(len(HALPE_26), 0.9)]


@pytest.fixture(scope="module")
def tiny_recording(tiny_original, tmp_path_factory) -> Path:
    """The tiny sequence as a recording with good OpenPose JSON keypoints of every frame."""
    root = write_recording(Sequence.open(tiny_original), tmp_path_factory.mktemp("rec") / "rec", progress=False)
    for camera in CAMERAS:
        for frame in range(FRAMES):
            write_openpose_json(openpose_path(root, camera, frame), [PERSON])
    return root


@pytest.fixture
def recording(tiny_recording, tmp_path) -> Path:
    return Path(shutil.copytree(tiny_recording, tmp_path / "rec"))


def one_joint(root: Path, x, y, confidence) -> list[str]:
    """BW1's frame 1 with joint LHip (the 12th) at ``x, y`` and ``confidence``, written as
    Python's json writes NaN and infinities (``NaN``, ``Infinity``)."""
    values = PERSON.copy()
    values[HALPE_26.index("LHip")] = x, y, confidence
    path = openpose_path(root, "BW1", 1)
    path.write_text(json.dumps({"version": 1.3, "people": [{"pose_keypoints_2d": values.ravel().tolist()}]}))
    return []


def rewrite(root: Path, text: str) -> list[str]:
    """C1's frame 0 file holding ``text``."""
    openpose_path(root, "C1", 0).write_text(text)
    return []


def short_person(root: Path) -> list[str]:
    path = openpose_path(root, "C1", 1)
    write_openpose_json(path, [PERSON[:25]])
    return []


def table(root: Path, confidence: float) -> list[str]:
    """The keypoints as ``keypoints.csv`` instead, one row's confidence ``confidence``."""
    shutil.rmtree(root / "pose")
    rows = ["frame,camera,joint,u,v,confidence"]
    for frame in range(FRAMES):
        for camera in CAMERAS:
            rows += [f"{frame},{camera},{joint},{u},{v},{c}" for joint, (u, v, c) in zip(HALPE_26, PERSON)]
    rows[5] = rows[5].rsplit(",", 1)[0] + f",{confidence}"
    (root / KEYPOINTS_CSV).write_text("\n".join(rows) + "\n")
    return []


def cut_table(root: Path) -> list[str]:
    """The keypoints as ``keypoints.csv``, cut inside its last row's confidence."""
    table(root, 0.5)
    path = root / KEYPOINTS_CSV
    path.write_text(path.read_text()[:-4])
    return []


CASES = {
    "wrong-value-count": (short_person, ["C1_000001.json", "person 1", "75 values", "HALPE_26", "keypoints.skeleton"]),
    "missing-frame": (
        lambda root: openpose_path(root, "BW1", 1).unlink() or [],
        ["camera BW1", "BW1_json lacks frame 1", "BW1_000001.json"],
    ),
    "camera-without-keypoints": (
        lambda root: shutil.rmtree(root / "pose" / "BW1_json") or [],
        ["no keypoints of camera(s) BW1", "BW1_json", "dataset.cameras"],
    ),
    "keypoints-of-an-unknown-camera": (
        lambda root: (root / "pose" / "cam03_json").mkdir() or [],
        ["camera(s) cam03", "calibration lacks", "C1, BW1"],
    ),
    "nan-coordinate": (lambda root: one_joint(root, float("nan"), 50.0, 0.8), ["BW1_000001.json", "LHip", "nan"]),
    "infinite-coordinate": (lambda root: one_joint(root, 20.0, float("inf"), 0.5), ["BW1_000001.json", "LHip", "inf"]),
    "confidence-above-one": (
        lambda root: one_joint(root, 20.0, 30.0, 1.5),
        ["BW1_000001.json", "LHip", "confidence 1.5", "outside [0, 1]"],
    ),
    "negative-confidence": (lambda root: one_joint(root, 20.0, 30.0, -0.2), ["BW1_000001.json", "confidence -0.2"]),
    "unreadable-json": (
        lambda root: rewrite(root, '{"people": ['),
        ["C1_000000.json", "not valid JSON"],
    ),
    "json-cut-short": (
        lambda root: rewrite(root, openpose_path(root, "C1", 0).read_text()[:-7]),
        ["C1_000000.json", "not valid JSON"],
    ),
    "table-cut-inside-a-row": (
        cut_table,
        [KEYPOINTS_CSV, "no line end", "cut short"],
    ),
    "json-without-people": (
        lambda root: rewrite(root, '{"version": 1.3}'),
        ["C1_000000.json", "'people'"],
    ),
    "unknown-skeleton": (lambda root: ["++keypoints.skeleton=HALPE26"], ["keypoints.skeleton", "HALPE26", "HALPE_26"]),
    "skeleton-of-other-files": (
        lambda root: ["++keypoints.skeleton=COCO_17"],
        ["C1_000000.json", "78 values", "COCO_17 has 17 joints"],
    ),
    "table-confidence-above-one": (
        lambda root: table(root, 2.0),
        [KEYPOINTS_CSV, "line 6, joint REar", "confidence 2"],
    ),
    "keypoints-twice": (
        lambda root: table(root, 0.5) or write_openpose_json(openpose_path(root, "C1", 0), [PERSON]) or [],
        ["holds keypoints twice", KEYPOINTS_CSV, "keep one"],
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_keypoints_are_one_line(recording, case):
    breaker, culprits = CASES[case]
    extra = breaker(recording)
    assert_clean_error(mmocap("check-recording", str(recording), *extra), *culprits)


def test_good_keypoints_pass_the_check(recording):
    outcome = mmocap("check-recording", str(recording))
    assert outcome.code == 0, outcome
    assert f"keypoints: {recording / 'pose'}: HALPE_26 (26 joints), {FRAMES} frames of 2 camera(s)" in outcome.stdout


@pytest.mark.parametrize("skeleton", list(MAPPINGS))
def test_a_mapping_without_the_root_or_both_hips_is_one_line_naming_the_fix(skeleton):
    """The mapping onto the model's points must locate the pelvis (the automatic start and the
    root's position rest on it): without the root and with one hip at most, it is refused."""
    pelvis_free = {joint: target for joint, target in MAPPINGS[skeleton].items() if target[0] not in ("Root", "LHip")}
    with pytest.raises(ConfigError) as caught:
        check_mapping(skeleton, pelvis_free)
    message = str(caught.value)
    assert "\n" not in message
    for culprit in (skeleton, "leaves the root and the hips unmapped", "Root", "LHip and RHip"):
        assert culprit in message
