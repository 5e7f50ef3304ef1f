import json

import cv2
import numpy as np
import pytest

from mmocap.camera import Camera
from mmocap.errors import DataError


@pytest.fixture
def camera():
    return Camera.look_at("C1", (3000, 1800, 2500), (0, 900, 0), 620.0, 640, 480,
                          dist=(-0.22, 0.11, 8e-4, -6e-4, 0.02))


def test_projection_agrees_with_opencv(camera):
    rng = np.random.default_rng(0)
    points = rng.uniform([-800, 0, -800], [800, 1900, 800], size=(500, 3))
    rvec, _ = cv2.Rodrigues(camera.R)
    expected, _ = cv2.projectPoints(points, rvec, camera.t, camera.K, camera.dist)
    np.testing.assert_allclose(camera.project(points), expected[:, 0], atol=1e-6)
    # and without distortion it is K [R|t]
    ideal = camera.ideal()
    h = np.c_[points, np.ones(len(points))] @ ideal.projection_matrix.T
    np.testing.assert_allclose(ideal.project(points), h[:, :2] / h[:, 2:], atol=1e-6)


def test_look_at_points_the_optical_axis_at_the_target(camera):
    uv = camera.ideal().project(np.array([[0.0, 900.0, 0.0]]))[0]
    np.testing.assert_allclose(uv, camera.K[:2, 2], atol=1e-6)
    # image rows grow downwards: a higher point has a smaller row
    up = camera.ideal().project(np.array([[0.0, 1500.0, 0.0]]))[0]
    assert up[1] < uv[1]
    np.testing.assert_allclose(camera.centre, (3000, 1800, 2500), atol=1e-6)


def test_undistortion_maps_recover_the_pinhole_image(camera):
    """A dot drawn where the lens puts it lands, after undistortion, where the pin-hole does."""
    ray = np.linalg.inv(camera.K) @ np.array([70.0, 60.0, 1.0])  # near a corner
    point = (camera.R.T @ (3000.0 * ray - camera.t))[None]
    u, v = np.round(camera.project(point)[0]).astype(int)
    mask = np.zeros((480, 640), bool)
    mask[v - 2:v + 3, u - 2:u + 3] = True
    undistorted = camera.undistort_mask(mask)
    rows, cols = np.nonzero(undistorted)
    ideal_uv = camera.ideal().project(point)[0]
    assert abs(cols.mean() - ideal_uv[0]) < 1.0 and abs(rows.mean() - ideal_uv[1]) < 1.0
    assert np.hypot(*(ideal_uv - (u, v))) > 3  # the lens really moved it


def test_save_load_round_trip(tmp_path, camera):
    camera.save(tmp_path / "C1.json")
    loaded = Camera.load(tmp_path / "C1.json")
    for attr in ("K", "dist", "R", "t"):
        np.testing.assert_allclose(getattr(loaded, attr), getattr(camera, attr))
    assert (loaded.width, loaded.height, loaded.name) == (640, 480, "C1")


def test_bad_calibration_files_name_the_file(tmp_path, camera):
    with pytest.raises(DataError, match="not found.*C7.json"):
        Camera.load(tmp_path / "C7.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    with pytest.raises(DataError, match="bad.json.*not valid JSON"):
        Camera.load(bad)
    d = camera.to_dict()
    d["K"] = [[1, 0], [0, 1]]
    bad.write_text(json.dumps(d))
    with pytest.raises(DataError, match="bad.json.*'K'"):
        Camera.load(bad)
    d = camera.to_dict()
    del d["t_mm"]
    bad.write_text(json.dumps(d))
    with pytest.raises(DataError, match="lacks the field 't_mm'"):
        Camera.load(bad)
    d = camera.to_dict()
    d["R"] = (2 * np.eye(3)).tolist()
    bad.write_text(json.dumps(d))
    with pytest.raises(DataError, match="not a rotation"):
        Camera.load(bad)


def test_cal_round_trip_projects_the_same(tmp_path, camera):
    skewed = Camera(camera.name, camera.K + np.array([[0, 0.4, 0], [0, 0, 0], [0, 0, 0]]),
                    camera.dist, camera.R, camera.t, 640, 480)
    path = tmp_path / "C1.cal"
    skewed.save_cal(path)
    assert len(path.read_text().split()) == 22
    loaded = Camera.load_cal(path, 640, 480)
    points = np.random.default_rng(1).uniform([-800, 0, -800], [800, 1900, 800], size=(200, 3))
    np.testing.assert_allclose(loaded.project(points), skewed.project(points), atol=1e-9)
    assert (loaded.name, loaded.width, loaded.height, loaded.colour) == ("C1", 640, 480, True)
    assert not Camera.load_cal(path, 640, 480, colour=False, name="BW1").colour


def test_cal_layout_is_fc_cc_alpha_kc_r_t(tmp_path):
    """The numbers of a hand-written file land where Bouguet's toolbox puts them."""
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    numbers = [600, 610, 320.5, 240.5, 0.001, -0.2, 0.1, 1e-3, -2e-3, 0.01, *R.ravel(), 10, -20, 4000]
    path = tmp_path / "BW2.cal"
    path.write_text("\n".join(map(str, numbers)) + "\n")
    cam = Camera.load_cal(path, 640, 480)
    np.testing.assert_allclose(cam.K, [[600, 0.6, 320.5], [0, 610, 240.5], [0, 0, 1]])
    np.testing.assert_allclose(cam.dist, [-0.2, 0.1, 1e-3, -2e-3, 0.01])
    np.testing.assert_allclose(cam.R, R)
    np.testing.assert_allclose(cam.t, [10, -20, 4000])
    assert cam.name == "BW2"


@pytest.mark.parametrize("text, message", [
    ("600 610 320 240 0 0 0 0 0 0 1 0 0 0 1 0 0 0 1 0 0", "holds 21 numbers.*22"),
    ("600 610 320 240 0 0 0 0 0 0 1 0 0 0 1 0 0 0 1 0 0 abc", "non-numeric"),
    ("600 610 320 240 0 0 0 0 0 0 2 0 0 0 1 0 0 0 1 0 0 0", "not a rotation"),
    ("-600 610 320 240 0 0 0 0 0 0 1 0 0 0 1 0 0 0 1 0 0 0", "focal lengths"),
    ("600 610 320 240 0 0 0 0 0 0 1 0 0 0 1 0 0 0 1 0 0 nan", "finite"),
])
def test_bad_cal_files_name_the_file(tmp_path, text, message):
    path = tmp_path / "C2.cal"
    path.write_text(text)
    with pytest.raises(DataError, match=f"C2.cal.*{message}"):
        Camera.load_cal(path, 640, 480)


def test_missing_cal_file_names_it(tmp_path):
    with pytest.raises(DataError, match="not found.*C3.cal"):
        Camera.load_cal(tmp_path / "C3.cal", 640, 480)
