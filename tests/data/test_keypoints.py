"""mmocap.data.keypoints: OpenPose JSON files in Pose2Sim's layout and the keypoint table read
back whole, the skeleton told from the files, several people and nobody handled as documented."""

import shutil
import warnings
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mmocap.camera import Camera
from mmocap.data.keypoints import (
    CSV_COLUMNS,
    KEYPOINTS_CSV,
    KeypointFiles,
    frame_ranges,
    openpose_path,
    read_people,
    write_openpose_json,
)
from mmocap.data.sequence import Sequence
from mmocap.data.skeletons import SKELETONS
from mmocap.errors import ConfigError, DataError, MmocapWarning
from tests.helpers import damages, read_or_refused

CAMERAS = ["C1", "C2"]
FRAMES = 4


def detections(skeleton: str, seed: int = 0) -> np.ndarray:
    """(FRAMES, C, J, 3) pixels on a millipixel grid (what the writer keeps) and confidences in
    (0, 1], one joint per camera and frame not seen (0, 0, 0)."""
    rng = np.random.default_rng(seed)
    J = len(SKELETONS[skeleton])
    data = np.concatenate(
        [rng.uniform(0, 640, (FRAMES, len(CAMERAS), J, 2)), rng.uniform(0.05, 1, (FRAMES, len(CAMERAS), J, 1))], axis=3
    ).round(3)
    data[:, :, 1] = 0.0
    return data


def write_json(root, data, first: int = 0) -> None:
    for k, frame in enumerate(data):
        for c, camera in enumerate(CAMERAS):
            write_openpose_json(openpose_path(root, camera, first + k), [frame[c]])


def write_csv(root, data, joints) -> None:
    F, C, J, _ = data.shape
    index = np.indices((F, C, J)).reshape(3, -1)
    values = data.reshape(-1, 3)
    table = pd.DataFrame(
        {
            "frame": index[0],
            "camera": np.asarray(CAMERAS)[index[1]],
            "joint": np.asarray(joints)[index[2]],
            "u": values[:, 0],
            "v": values[:, 1],
            "confidence": values[:, 2],
        }
    )
    table.to_csv(root / KEYPOINTS_CSV, index=False)


@pytest.mark.parametrize("skeleton", list(SKELETONS))
def test_openpose_files_read_back_with_their_skeleton_told_by_the_value_count(tmp_path, skeleton):
    data = detections(skeleton)
    write_json(tmp_path, data)
    assert KeypointFiles.has(tmp_path)
    files = KeypointFiles(tmp_path, CAMERAS, FRAMES)
    assert files.skeleton == skeleton
    assert files.joints == SKELETONS[skeleton]
    for k in range(FRAMES):
        got = files.frame(k)
        assert got.shape == (len(CAMERAS), len(SKELETONS[skeleton]), 3)
        assert got.dtype == np.float64
        np.testing.assert_array_equal(got, data[k])


def test_the_camera_order_is_the_one_given(tmp_path):
    data = detections("COCO_17")
    write_json(tmp_path, data)
    files = KeypointFiles(tmp_path, CAMERAS[::-1], FRAMES, "COCO_17")
    np.testing.assert_array_equal(files.frame(2), data[2, ::-1])


def test_a_named_skeleton_must_match_the_files_and_an_unknown_one_is_refused(tmp_path):
    write_json(tmp_path, detections("HALPE_26"))
    with pytest.raises(DataError, match=r"C1_000000.json, person 1: 78 values, but COCO_17 has 17 joints x 3"):
        KeypointFiles(tmp_path, CAMERAS, FRAMES, "COCO_17")
    with pytest.raises(ConfigError, match=r"keypoints.skeleton: unknown keypoint skeleton 'HALPE26'; known: auto, "):
        KeypointFiles(tmp_path, CAMERAS, FRAMES, "HALPE26")


def test_the_frame_number_is_the_name_s_trailing_digits_and_files_start_at_the_first_frame(tmp_path):
    """Pose2Sim names files of an image folder after each image; only the trailing
    ``_<digits>`` counts. Frame k of the sequence is file frame first + k."""
    data = detections("BODY_25")
    for k, frame in enumerate(data):
        for c, camera in enumerate(CAMERAS):
            path = tmp_path / "pose" / f"{camera}_json" / f"img_{k:03d}_{k + 7:06d}.json"
            write_openpose_json(path, [frame[c]])
    files = KeypointFiles(tmp_path, CAMERAS, FRAMES - 1, first_frames=[8, 7])
    np.testing.assert_array_equal(files.frame(0)[0], data[1, 0])  # C1: frame 8
    np.testing.assert_array_equal(files.frame(0)[1], data[0, 1])  # C2: frame 7
    with pytest.raises(DataError, match=r"camera C1: .*C1_json lacks frame 11 .* e.g. C1_000011.json"):
        KeypointFiles(tmp_path, CAMERAS, FRAMES, first_frames=[8, 7])


def test_of_several_people_the_most_confident_is_taken_with_one_warning_per_camera(tmp_path):
    data = detections("COCO_17")
    write_json(tmp_path, data)
    weaker = data[0, 0].copy()
    weaker[:, 2] *= 0.5
    stronger = data[1, 0].copy()
    stronger[:, 2] = np.minimum(1.0, stronger[:, 2] * 2)
    write_openpose_json(openpose_path(tmp_path, "C1", 0), [weaker, data[0, 0]])
    write_openpose_json(openpose_path(tmp_path, "C1", 1), [data[1, 0], stronger])
    write_openpose_json(openpose_path(tmp_path, "C1", 3), [data[3, 0], weaker])
    with pytest.warns(MmocapWarning) as caught:
        files = KeypointFiles(tmp_path, CAMERAS, FRAMES)
    assert len(caught) == 1
    assert "camera C1:" in str(caught[0].message)
    assert "3 of 4 frames (0-1, 3)" in str(caught[0].message)
    np.testing.assert_array_equal(files.frame(0)[0], data[0, 0])
    np.testing.assert_array_equal(files.frame(1)[0], stronger)
    np.testing.assert_array_equal(files.frame(3)[0], data[3, 0])


def test_a_frame_without_a_person_has_every_joint_unseen(tmp_path):
    data = detections("HALPE_26")
    write_json(tmp_path, data)
    write_openpose_json(openpose_path(tmp_path, "C2", 2), [])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        files = KeypointFiles(tmp_path, CAMERAS, FRAMES)
    assert not files.frame(2)[1].any()
    np.testing.assert_array_equal(files.frame(2)[0], data[2, 0])


def test_shrunk_cameras_shrink_the_seen_joints_as_the_cameras_are(tmp_path):
    data = detections("COCO_17")
    write_json(tmp_path, data)
    big = Camera("C1", np.diag([500.0, 500.0, 1.0]), np.zeros(5), np.eye(3), np.zeros(3), 640, 480)
    small = replace(big, width=320, height=120)  # only the sizes matter here
    files = KeypointFiles(tmp_path, CAMERAS, FRAMES, shrunk=[(big, small), (big, big)])
    got, seen = files.frame(1), data[1, 0, :, 2] > 0
    np.testing.assert_allclose(got[0, seen, 0], (data[1, 0, seen, 0] + 0.5) * 0.5 - 0.5)
    np.testing.assert_allclose(got[0, seen, 1], (data[1, 0, seen, 1] + 0.5) * 0.25 - 0.5)
    np.testing.assert_array_equal(got[0, ~seen], 0.0)
    np.testing.assert_array_equal(got[1], data[1, 1])


def test_the_table_reads_as_the_json_files_do_and_tells_the_skeleton_by_its_joint_names(tmp_path):
    data = detections("HALPE_26", seed=1)
    write_json(tmp_path / "json", data)
    write_csv(tmp_path / "json", data, SKELETONS["HALPE_26"])
    with pytest.raises(DataError, match="holds keypoints twice"):
        KeypointFiles(tmp_path / "json", CAMERAS, FRAMES)
    shutil.rmtree(tmp_path / "json" / "pose")
    from_csv = KeypointFiles(tmp_path / "json", CAMERAS, FRAMES)
    assert from_csv.skeleton == "HALPE_26"
    write_json(tmp_path / "again", data)
    from_json = KeypointFiles(tmp_path / "again", CAMERAS, FRAMES)
    for k in range(FRAMES):
        np.testing.assert_array_equal(from_csv.frame(k), from_json.frame(k))


def test_a_table_s_rows_left_out_are_unseen_joints_and_coco_names_are_coco_17(tmp_path):
    data = detections("HALPE_26", seed=2)[:, :, :17]
    write_csv(tmp_path, data, SKELETONS["COCO_17"])
    table = pd.read_csv(tmp_path / KEYPOINTS_CSV)
    assert list(table.columns) == list(CSV_COLUMNS)
    table = table[~((table["joint"] == "LKnee") & (table["frame"] == 1))]
    table.to_csv(tmp_path / KEYPOINTS_CSV, index=False)
    files = KeypointFiles(tmp_path, CAMERAS, FRAMES)
    assert files.skeleton == "COCO_17"
    knee = SKELETONS["COCO_17"].index("LKnee")
    assert not files.frame(1)[:, knee].any()
    np.testing.assert_array_equal(files.frame(2), data[2])


def test_a_folder_without_keypoints_has_none(tmp_path):
    assert not KeypointFiles.has(tmp_path)
    (tmp_path / "pose" / "C1_pose.mp4").parent.mkdir()
    assert not KeypointFiles.has(tmp_path)  # Pose2Sim's videos and image folders are not keypoints
    (tmp_path / "pose" / "C1_json").mkdir()
    assert KeypointFiles.has(tmp_path)


def test_frame_ranges_join_runs():
    assert frame_ranges([9, 3, 4, 5, 11, 12]) == "3-5, 9, 11-12"
    assert frame_ranges([7]) == "7"


def test_a_sequence_folder_reports_the_keypoint_files_of_its_root(tiny_sequence, tmp_path):
    root = shutil.copytree(tiny_sequence, tmp_path / "seq")
    sequence = Sequence.open(root, ["BW1", "C1"])
    assert not sequence.has_keypoints
    with pytest.raises(DataError, match="has no keypoint files"):
        sequence.keypoint_files()
    rng = np.random.default_rng(3)
    observed = {}
    for camera in sequence.meta["cameras"]:
        for k in range(sequence.n_frames):
            observed[camera, k] = np.c_[rng.uniform(0, 300, (17, 2)), rng.uniform(0.1, 1, 17)].round(3)
            write_openpose_json(openpose_path(root, camera, k), [observed[camera, k]])
    assert sequence.has_keypoints
    files = sequence.keypoint_files("COCO_17")
    np.testing.assert_array_equal(files.frame(3), [observed["BW1", 3], observed["C1", 3]])


def test_a_table_with_a_row_twice_or_a_frame_short_is_refused_naming_the_line_or_frame(tmp_path):
    data = detections("COCO_17")
    write_csv(tmp_path, data, SKELETONS["COCO_17"])
    lines = (tmp_path / KEYPOINTS_CSV).read_text().splitlines()
    (tmp_path / KEYPOINTS_CSV).write_text("\n".join([*lines, lines[40]]) + "\n")
    with pytest.raises(DataError, match=r"keypoints.csv: line 41: frame, camera and joint appear again"):
        KeypointFiles(tmp_path, CAMERAS, FRAMES)
    table = pd.DataFrame([line.split(",") for line in lines[1:]], columns=lines[0].split(","))
    table[~((table["frame"] == "2") & (table["camera"] == "C2"))].to_csv(tmp_path / KEYPOINTS_CSV, index=False)
    with pytest.raises(DataError, match=r"camera C2: .*keypoints.csv lacks frame 2 \(1 of the sequence's 4"):
        KeypointFiles(tmp_path, CAMERAS, FRAMES)


def test_a_table_beside_pose2sim_s_videos_is_read_and_no_files_at_all_are_refused(tmp_path):
    with pytest.raises(DataError, match="holds no keypoint files"):
        KeypointFiles(tmp_path, CAMERAS, FRAMES)
    data = detections("BODY_25")
    write_csv(tmp_path, data, SKELETONS["BODY_25"])
    (tmp_path / "pose" / "C1_img").mkdir(parents=True)  # not keypoints: no "holds keypoints twice"
    np.testing.assert_array_equal(KeypointFiles(tmp_path, CAMERAS, FRAMES).frame(3), data[3])


# --- files cut short or damaged (Hypothesis: tests/helpers.py damages) -----------------------

#: two frames of both cameras, the smallest table that still has a second frame to lose
SMALL = detections("COCO_17")[:2]


@pytest.fixture(scope="module")
def keypoint_table(tmp_path_factory):
    """A folder holding the :data:`KEYPOINTS_CSV` of :data:`SMALL`, and its bytes."""
    root = tmp_path_factory.mktemp("keypoint_table")
    write_csv(root, SMALL, SKELETONS["COCO_17"])
    return root, (root / KEYPOINTS_CSV).read_bytes()


@settings(max_examples=100)
@given(data=st.data())
def test_a_cut_keypoint_table_is_refused_or_read_as_its_whole_rows(keypoint_table, data):
    """A cut inside a row is refused; a cut at a row's end gives exactly the rows kept, the
    joints of the rows lost unseen (a row left out is a joint not found), or is refused when
    a camera's last frame has no row left."""
    root, whole = keypoint_table
    damage = data.draw(damages(whole, ("cut",)))
    (root / KEYPOINTS_CSV).write_bytes(damage.apply(whole))
    outcome = read_or_refused(KeypointFiles, KEYPOINTS_CSV, root, CAMERAS, len(SMALL), "COCO_17")
    rows = damage.whole_lines(whole) - 1
    F, C, J, _ = SMALL.shape
    if not whole[: damage.offset].endswith(b"\n") or rows <= (F - 1) * C * J + (C - 1) * J:
        assert outcome is None, f"{damage}: read, not refused"
        return
    assert outcome is not None, f"{damage}: refused, but every frame has its rows"
    expected = SMALL.reshape(-1, 3).copy()
    expected[rows:] = 0.0
    np.testing.assert_array_equal(np.stack([outcome[0].frame(k) for k in range(F)]), expected.reshape(SMALL.shape))


@settings(max_examples=100)
@given(data=st.data())
def test_a_damaged_byte_of_a_keypoint_table_changes_one_joint_at_most(keypoint_table, data):
    root, whole = keypoint_table
    damage = data.draw(damages(whole, ("byte",)))
    (root / KEYPOINTS_CSV).write_bytes(damage.apply(whole))
    outcome = read_or_refused(KeypointFiles, KEYPOINTS_CSV, root, CAMERAS, len(SMALL), "COCO_17")
    if outcome is not None:
        read = np.stack([outcome[0].frame(k) for k in range(len(SMALL))])
        assert (read != SMALL).any(axis=3).sum() <= 1, f"{damage}: more than one joint differs"


@pytest.fixture(scope="module")
def openpose_file(tmp_path_factory):
    """One OpenPose JSON file of two people (write_openpose_json), and its bytes."""
    path = tmp_path_factory.mktemp("openpose") / "C1_000000.json"
    write_openpose_json(path, [SMALL[0, 0], SMALL[1, 1]])
    return path, path.read_bytes()


@settings(max_examples=100)
@given(data=st.data())
def test_a_damaged_openpose_file_is_refused_or_read_as_it_says(openpose_file, data):
    """A cut JSON file is refused (it does not parse); a byte changed is refused or read."""
    path, whole = openpose_file
    damage = data.draw(damages(whole))
    path.write_bytes(damage.apply(whole))
    outcome = read_or_refused(read_people, path.name, path)
    if damage.kind == "cut":
        assert outcome is None, f"{damage}: read, not refused"
    elif outcome is not None:
        assert all(person.dtype == np.float64 and person.ndim == 1 for person in outcome[0])
