import json

import cv2
import numpy as np
import pandas as pd
import pytest

from mmocap.body.model import MARKER_NAMES, BodyModel
from mmocap.data.motion import ACTIONS, generate_motion
from mmocap.data.sequence import Sequence
from mmocap.errors import ConfigError, DataError
from mmocap.stages.evaluation import marker_error


def test_layout_on_disk(tiny_sequence):
    root = tiny_sequence
    meta = json.loads((root / "sequence.json").read_text())
    assert meta["format"] == "mmocap-sequence/1"
    assert meta["cameras"] == ["C1", "C2", "BW1"]
    assert meta["frames"] == 4 and meta["fps"] == 60.0 and meta["subject"] == "S1"
    assert meta["dimensions"]["height_mm"] == 1780.0
    assert len(meta["x0"]) == 51
    for cam in meta["cameras"]:
        assert (root / "calibration" / f"{cam}.json").is_file()
        assert len(list((root / "background" / cam).glob("*.png"))) == 3
        assert len(list((root / "images" / cam).glob("*.png"))) == 4
        assert len(list((root / "silhouettes" / cam).glob("*.png"))) == 4
    colour = cv2.imread(str(root / "images" / "C1" / "000000.png"), cv2.IMREAD_UNCHANGED)
    grey = cv2.imread(str(root / "images" / "BW1" / "000000.png"), cv2.IMREAD_UNCHANGED)
    assert colour.shape == (240, 320, 3) and grey.shape == (240, 320)
    table = pd.read_csv(root / "markers_mm.csv")
    assert list(table.columns) == ["frame", "marker", "x_mm", "y_mm", "z_mm"]
    assert len(table) == 4 * len(MARKER_NAMES)
    assert np.load(root / "poses.npy").shape == (4, 51)


def test_ground_truth_is_consistent_but_not_the_trackers_model(tiny_sequence):
    seq = Sequence.open(tiny_sequence)
    truth = seq.markers()
    poses = np.load(tiny_sequence / "poses.npy")
    np.testing.assert_allclose(seq.x0, poses[0])
    body = BodyModel("S1")
    err = marker_error(body.markers(poses), truth)
    # the tracker's rigid markers at the true pose sit close to, but not exactly on, the
    # skinned mesh's markers: the data is not rendered from the tracker's own model
    assert np.all(err < 15) and np.all(err > 0.05)
    # the person is in every view: silhouettes cover a sensible part of the image
    for cam in seq.cameras:
        area = seq.silhouette(0, cam).mean()
        assert 0.01 < area < 0.5, cam.name
    # and the markers project inside the silhouettes (through the real, distorted lens)
    cam = seq.cameras[0]
    uv = np.round(cam.project(truth[0])).astype(int)
    sil = cv2.dilate(seq.silhouette(0, cam).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert sil[uv[:, 1], uv[:, 0]].mean() > 0.9


@pytest.mark.parametrize("action", ACTIONS)
def test_motion_is_smooth_and_moves(action):
    poses = generate_motion(action, 120, 60.0, floor_offset_mm=950.0, seed=2)
    step = np.abs(np.diff(poses[:, 3:], axis=0)).max()
    assert step < 0.25  # rad per frame at 60 fps: fast punches, but within the 0.5 rad radius
    assert np.ptp(poses[:, 3:], axis=0).max() > 0.5  # something moves a lot
    assert np.all(poses[:, 1] > 700)  # the root stays above the floor


def test_sequence_reader_errors(tiny_sequence, tmp_path):
    with pytest.raises(DataError, match="camera C3 not in sequence"):
        Sequence.open(tiny_sequence, cameras=["C1", "C3"])
    with pytest.raises(DataError, match="no sequence.json"):
        Sequence.open(tmp_path)
    with pytest.raises(ConfigError, match="unknown action"):
        generate_motion("juggling", 10, 60.0, 950.0)
