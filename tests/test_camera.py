import json
import tracemalloc

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mmocap.camera import MAX_IMAGE_SIDE_PX, Camera, checked_camera
from mmocap.errors import DataError
from tests.helpers import damages, read_damaged


@pytest.fixture
def camera():
    return Camera.look_at("C1", (3000, 1800, 2500), (0, 900, 0), 620.0, 640, 480, dist=(-0.22, 0.11, 8e-4, -6e-4, 0.02))


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
    mask[v - 2 : v + 3, u - 2 : u + 3] = True
    undistorted = camera.undistort_mask(mask)
    rows, cols = np.nonzero(undistorted)
    ideal_uv = camera.ideal().project(point)[0]
    assert abs(cols.mean() - ideal_uv[0]) < 1.0
    assert abs(rows.mean() - ideal_uv[1]) < 1.0
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
    skewed = Camera(
        camera.name, camera.K + np.array([[0, 0.4, 0], [0, 0, 0], [0, 0, 0]]), camera.dist, camera.R, camera.t, 640, 480
    )
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


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("600 610 320 240 0 0 0 0 0 0 1 0 0 0 1 0 0 0 1 0 0", "holds 21 numbers.*22"),
        ("600 610 320 240 0 0 0 0 0 0 1 0 0 0 1 0 0 0 1 0 0 abc", "non-numeric"),
        ("600 610 320 240 0 0 0 0 0 0 2 0 0 0 1 0 0 0 1 0 0 0", "not a rotation"),
        ("-600 610 320 240 0 0 0 0 0 0 1 0 0 0 1 0 0 0 1 0 0 0", "focal lengths"),
        ("600 610 320 240 0 0 0 0 0 0 1 0 0 0 1 0 0 0 1 0 0 nan", "finite"),
    ],
)
def test_bad_cal_files_name_the_file(tmp_path, text, message):
    path = tmp_path / "C2.cal"
    path.write_text(text + "\n")
    with pytest.raises(DataError, match=f"C2.cal.*{message}"):
        Camera.load_cal(path, 640, 480)


def test_missing_cal_file_names_it(tmp_path):
    with pytest.raises(DataError, match="not found.*C3.cal"):
        Camera.load_cal(tmp_path / "C3.cal", 640, 480)


# --- the one validation of every reader ----------------------------------------------------


def good_values(camera) -> dict:
    return dict(
        name=camera.name,
        K=camera.K.tolist(),
        dist=camera.dist.tolist(),
        R=camera.R.tolist(),
        t=camera.t.tolist(),
        width=camera.width,
        height=camera.height,
        colour=True,
    )


def test_checked_camera_keeps_good_values(camera):
    checked = checked_camera("test", **good_values(camera))
    for attr in ("K", "dist", "R", "t"):
        np.testing.assert_array_equal(getattr(checked, attr), getattr(camera, attr))
    assert (checked.name, checked.width, checked.height, checked.colour) == ("C1", 640, 480, True)


def with_item(key, index, value):
    def change(values):
        array = np.array(values[key], dtype=float)
        array[index] = value
        values[key] = array.tolist()

    return change


def with_value(key, value):
    return lambda values: values.__setitem__(key, value)


BAD_VALUES = {
    "negative fx": (with_item("K", (0, 0), -620.0), "'K' focal lengths fx = -620"),
    "zero fy": (with_item("K", (1, 1), 0.0), "'K' focal lengths.*fy = 0"),
    "K not upper triangular": (with_item("K", (1, 0), 3.0), r"'K' must be \[\[fx, skew, cx\]"),
    "K[2, 2] not 1": (with_item("K", (2, 2), 2.0), r"'K' must be \[\[fx"),
    "K with NaN": (with_item("K", (0, 2), np.nan), "'K' must hold finite numbers"),
    "K ragged": (with_value("K", [[1, 2, 3], [4, 5]]), "'K' must be 3 x 3 numbers"),
    "principal point left of the image": (with_item("K", (0, 2), -400.0), "'K' principal point cx = -400"),
    "principal point below the image": (with_item("K", (1, 2), 800.0), "'K' principal point cy = 800"),
    "sheared R with det 1": (with_item("R", (0, 1), 0.5), "'R' is not a rotation"),
    "reflected R": (with_value("R", np.diag([1.0, 1.0, -1.0]).tolist()), "'R' is not a rotation"),
    "R of text": (with_value("R", "identity"), "'R' must be 3 x 3 numbers"),
    "dist with inf": (with_item("dist", 1, np.inf), "'dist' must hold finite numbers"),
    "dist of 4": (with_value("dist", [0.0, 0.0, 0.0, 0.0]), r"'dist' must be 5 numbers, got shape \(4,\)"),
    "t of 2": (with_value("t", [0.0, 0.0]), "'t_mm' must be 3 numbers"),
    "width 0": (with_value("width", 0), r"'width' must be an integer.*\[1, 16384\].*got 0"),
    "height 60000": (with_value("height", 60000), "'height' .*got 60000"),
    "width 640.5": (with_value("width", 640.5), "'width' .*got 640.5"),
    "width True": (with_value("width", True), "'width' .*got True"),
    "width text": (with_value("width", "640"), "'width' .*got '640'"),
    "colour text": (with_value("colour", "no"), "'colour' must be true or false"),
}


@pytest.mark.parametrize(("change", "message"), BAD_VALUES.values(), ids=BAD_VALUES.keys())
def test_checked_camera_names_source_camera_and_key(camera, change, message):
    values = good_values(camera)
    change(values)
    with pytest.raises(DataError, match=rf"^camera C1: calibration file X\.json: {message}"):
        checked_camera("calibration file X.json", **values)


def test_the_largest_side_is_accepted_and_one_more_is_not(camera):
    values = good_values(camera) | {"width": MAX_IMAGE_SIDE_PX, "K": np.diag([620.0, 620.0, 1.0]).tolist()}
    assert checked_camera("test", **values).width == MAX_IMAGE_SIDE_PX
    with pytest.raises(DataError, match="'width'"):
        checked_camera("test", **values | {"width": MAX_IMAGE_SIDE_PX + 1})


def test_an_absurd_size_is_refused_before_anything_allocates(tmp_path, camera):
    d = camera.to_dict() | {"width": 60000, "height": 40000}
    path = tmp_path / "C1.json"
    path.write_text(json.dumps(d))
    tracemalloc.start()
    try:
        with pytest.raises(DataError, match="C1.json.*'width'.*16384.*60000"):
            Camera.load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000  # a 60000x40000 map would take 9.6 GB


def test_json_and_cal_readers_refuse_the_same_camera_the_same_way(tmp_path, camera):
    """One validation whatever the reader: a sheared R that the JSON reader's old
    determinant-only check let through is refused by both, with the same words."""
    sheared = Camera(camera.name, camera.K, camera.dist, camera.R @ np.array(SHEAR), camera.t, 640, 480)
    assert abs(np.linalg.det(sheared.R) - 1) < 1e-9
    sheared.save(tmp_path / "C1.json")
    sheared.save_cal(tmp_path / "C1.cal")
    messages = []
    for load in (lambda: Camera.load(tmp_path / "C1.json"), lambda: Camera.load_cal(tmp_path / "C1.cal", 640, 480)):
        with pytest.raises(DataError) as caught:
            load()
        messages.append(str(caught.value).split(": ", 2)[2])  # after "camera C1: <file>: "
    assert messages[0] == messages[1]
    assert messages[0].startswith("'R' is not a rotation")


def test_cal_errors_use_the_cal_names(tmp_path, camera):
    values = Camera(
        camera.name, camera.K * np.array([[-1, 1, 1], [1, 1, 1], [1, 1, 1]]), camera.dist, camera.R, camera.t, 640, 480
    )
    values.save_cal(tmp_path / "C1.cal")
    with pytest.raises(DataError, match=r"camera C1: .*C1.cal: 'fc, cc, alpha_c' focal lengths"):
        Camera.load_cal(tmp_path / "C1.cal", 640, 480)


def test_a_json_that_is_not_an_object_or_lacks_a_key(tmp_path, camera):
    path = tmp_path / "BW3.json"
    path.write_text("[]")
    with pytest.raises(DataError, match=r"camera BW3: .*BW3.json is not a JSON object"):
        Camera.load(path)
    path.write_text(json.dumps({k: v for k, v in camera.to_dict().items() if k != "height"}))
    with pytest.raises(DataError, match=r"camera BW3: .*BW3.json lacks the field 'height'"):
        Camera.load(path)


# --- skew ----------------------------------------------------------------------------------

SHEAR = [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
ALPHA_C = 0.0043  # a HumanEva-I-sized skew (alpha_c, a fraction of fx)


@pytest.fixture
def skewed(camera):
    K = camera.K.copy()
    K[0, 1] = ALPHA_C * K[0, 0]
    return Camera(camera.name, K, camera.dist, camera.R, camera.t, 640, 480)


def test_opencv_drops_the_skew_so_it_is_applied_after(skewed):
    """``cv2.projectPoints`` reads only fx, fy, cx, cy: with the full K it gives the same
    pixels as without the skew. The skewed pixel is that one sheared by K K0^-1 (K0 = K
    without skew), which is what :meth:`Camera.project` gives; ``cv2.undistortPoints`` of
    the unsheared pixel returns the ray."""
    points = np.random.default_rng(2).uniform([-800, 0, -800], [800, 1900, 800], size=(300, 3))
    rvec, _ = cv2.Rodrigues(skewed.R)
    unskewed = skewed.K.copy()
    unskewed[0, 1] = 0.0
    full, _ = cv2.projectPoints(points, rvec, skewed.t, skewed.K, skewed.dist)
    plain, _ = cv2.projectPoints(points, rvec, skewed.t, unskewed, skewed.dist)
    np.testing.assert_allclose(full, plain)  # OpenCV ignores K[0, 1]
    shear = skewed.K @ np.linalg.inv(unskewed)
    expected = np.c_[plain[:, 0], np.ones(len(points))] @ shear[:2].T
    uv = skewed.project(points)
    np.testing.assert_allclose(uv, expected, atol=1e-6)
    assert np.abs(uv - plain[:, 0]).max() > 0.5  # the skew moves pixels by more than half a pixel
    unsheared = np.c_[uv, np.ones(len(uv))] @ np.linalg.inv(shear)[:2].T
    rays = cv2.undistortPoints(unsheared[:, None], unskewed, skewed.dist)[:, 0]
    camera_points = skewed.to_camera(points)
    np.testing.assert_allclose(rays, camera_points[:, :2] / camera_points[:, 2:], atol=1e-6)


def test_undistortion_maps_send_each_ideal_pixel_to_its_skewed_distorted_pixel(skewed):
    rows, cols = np.mgrid[20:480:60, 20:640:60]
    ideal = np.stack([cols.ravel(), rows.ravel()], axis=1).astype(float)
    rays = np.c_[ideal, np.ones(len(ideal))] @ np.linalg.inv(skewed.K).T  # z = 1 in the camera frame
    world = (rays * 2000.0 - skewed.t) @ skewed.R  # R^T (X_cam - t), row-wise
    expected = skewed.project(world)
    map_x, map_y = skewed.undistort_maps()
    got = np.stack([map_x[rows.ravel(), cols.ravel()], map_y[rows.ravel(), cols.ravel()]], axis=1)
    np.testing.assert_allclose(got, expected, atol=0.02)
    old_x, _ = cv2.initUndistortRectifyMap(skewed.K, skewed.dist, None, skewed.K, (640, 480), cv2.CV_32FC1)
    assert np.abs(old_x[rows.ravel(), cols.ravel()] - expected[:, 0]).max() > 0.5  # what the skew-blind map missed


def test_cal_alpha_c_reaches_projection_and_undistortion(tmp_path, skewed):
    skewed.save_cal(tmp_path / "C1.cal")
    assert float((tmp_path / "C1.cal").read_text().split()[4]) == pytest.approx(ALPHA_C)
    loaded = Camera.load_cal(tmp_path / "C1.cal", 640, 480)
    np.testing.assert_allclose(loaded.K, skewed.K)
    np.testing.assert_allclose(loaded.undistort_maps()[0], skewed.undistort_maps()[0], atol=1e-3)


def test_a_shrunk_camera_keeps_pixel_centres_at_integers():
    camera = Camera.look_at("C1", [3000.0, -2500.0, 1500.0], [0.0, 0.0, 900.0], 600.0, 640, 480)
    small = camera.shrunk(0.25)
    assert (small.width, small.height) == (160, 120)
    points = np.array([[0.0, 0.0, 900.0], [300.0, -200.0, 1700.0], [-250.0, 100.0, 50.0]])
    # the centre of full-size pixel u lies at (u + 0.5) / 4 - 0.5 in the shrunk picture
    np.testing.assert_allclose(small.project(points), (camera.project(points) + 0.5) * 0.25 - 0.5, atol=1e-9)
    odd = camera.shrunk(0.3)  # 192 x 144: the rounded size sets each axis's ratio
    np.testing.assert_allclose(
        odd.project(points), (camera.project(points) + 0.5) * [192 / 640, 144 / 480] - 0.5, atol=1e-9
    )
    lens = Camera.look_at(
        "C1", [3000.0, -2500.0, 1500.0], [0.0, 0.0, 900.0], 600.0, 640, 480, dist=(-0.2, 0.1, 0, 0, 0)
    )
    np.testing.assert_allclose(  # the lens acts before K: a distorted camera shrinks alike
        lens.shrunk(0.5).project(points), (lens.project(points) + 0.5) * 0.5 - 0.5, atol=1e-9
    )


@pytest.mark.parametrize("which", ["camera", "skewed"])
def test_ideal_pixels_invert_the_lens_over_the_whole_image(request, which):
    """Every raw pixel of the image (a 16-pixel grid, corners included) goes to the ideal
    pixel whose ray :meth:`Camera.project` puts back on it, to well under 0.01 px."""
    cam = request.getfixturevalue(which)
    rows, cols = np.mgrid[0 : cam.height : 16, 0 : cam.width : 16]
    raw = np.stack([cols.ravel(), rows.ravel()], axis=1).astype(float)
    raw = np.r_[raw, [[cam.width - 1, cam.height - 1], [0, cam.height - 1], [cam.width - 1, 0]]]
    ideal = cam.ideal_pixels(raw)
    rays = np.c_[ideal, np.ones(len(ideal))] @ np.linalg.inv(cam.K).T
    world = (rays * 2500.0 - cam.t) @ cam.R
    assert np.abs(cam.project(world) - raw).max() < 0.01
    assert np.abs(ideal - raw).max() > 20  # the lens moves the corners: nothing was left as it was


def test_ideal_pixels_of_a_camera_without_distortion_are_the_pixels(camera):
    pixels = np.array([[0.0, 0.0], [320.5, 240.25], [639.0, 479.0]])
    np.testing.assert_array_equal(camera.ideal().ideal_pixels(pixels), pixels)
    assert camera.ideal_pixels(np.zeros((0, 2))).shape == (0, 2)


# --- files cut short or damaged (Hypothesis: tests/helpers.py damages) -----------------------

#: the camera whose files the property tests damage
SMALL_CAMERA = Camera.look_at(
    "C1", (3000, 1800, 2500), (0, 900, 0), 62.0, 64, 48, dist=(-0.22, 0.11, 8e-4, -6e-4, 0.02)
)


@pytest.fixture(scope="module")
def camera_files(tmp_path_factory):
    """:data:`SMALL_CAMERA` as mmocap's JSON and as a HumanEva-I ``.cal``: name -> (path, bytes)."""
    folder = tmp_path_factory.mktemp("camera_files")
    SMALL_CAMERA.save(folder / "C1.json")
    SMALL_CAMERA.save_cal(folder / "C1.cal")
    return {name: (folder / name, (folder / name).read_bytes()) for name in ("C1.json", "C1.cal")}


def load_small(path):
    return Camera.load(path) if path.suffix == ".json" else Camera.load_cal(path, 64, 48, name="C1")


@pytest.mark.parametrize("name", ["C1.json", "C1.cal"])
@settings(max_examples=100)
@given(data=st.data())
def test_a_damaged_camera_file_is_refused_or_read_whole(camera_files, name, data):
    """A cut JSON file is refused unless only its last line end is lost; a cut ``.cal`` is
    refused (too few numbers) or read as HumanEva distributes it, with a warning that its last
    number may be cut; a byte changed is refused or read."""
    path, whole = camera_files[name]
    damage = data.draw(damages(whole))
    outcome = read_damaged(load_small, path, damage, whole)
    if damage.kind == "cut" and outcome is not None:
        read, messages = outcome
        if name == "C1.cal":
            assert any("has no line end: read as it is" in message for message in messages), f"{damage}: not warned"
            if damage.apply(whole) != whole.rstrip():
                return  # its last number may be shortened, as the warning says
        for attr in ("K", "dist", "R", "t"):
            np.testing.assert_array_equal(getattr(read, attr), getattr(SMALL_CAMERA, attr), err_msg=f"{damage}: {attr}")
