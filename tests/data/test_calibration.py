import logging
import re
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mmocap.camera import Camera
from mmocap.data.calibration import read_calibration, write_opencv_yaml
from mmocap.data.synthetic import camera_rig
from mmocap.errors import ConfigError, DataError
from tests.helpers import damages, qtm_calibration_xml, read_damaged, vicon_calibration_xml


@pytest.fixture
def rig() -> list[Camera]:
    """Three cameras about 4 m from the origin, with distortion (k3 = 0), two colour, one grey."""
    return camera_rig(["C1", "C2", "BW1"], 640, 480, np.random.default_rng(7))


def assert_same_cameras(read: list[Camera], expected: list[Camera], colour: bool = True):
    assert [c.name for c in read] == [c.name for c in expected]
    for got, want in zip(read, expected, strict=True):
        for attr in ("K", "dist", "R", "t"):
            scale = np.abs(getattr(want, attr)).max()
            np.testing.assert_allclose(
                getattr(got, attr), getattr(want, attr), rtol=1e-9, atol=1e-9 * scale, err_msg=f"{want.name}.{attr}"
            )
        assert (got.width, got.height) == (want.width, want.height)
        if colour:
            assert got.colour == want.colour


def rodrigues(R: np.ndarray) -> list[float]:
    return cv2.Rodrigues(R)[0].ravel().tolist()


def toml_list(values, trailing_comma: bool = False) -> str:
    return "[ " + ", ".join(repr(float(v)) for v in values) + ("," if trailing_comma else "") + "]"


def pose2sim_toml(cameras: list[Camera]) -> str:
    """Pose2Sim's calibration.py:toml_write: tables named after the cameras, float sizes,
    4 distortions, translations in metres, ``fisheye = false`` and a metadata table."""
    text = ""
    for c in cameras:
        matrix = "[ " + ", ".join(toml_list(row) for row in c.K) + "]"
        text += (
            f'[{c.name}]\nname = "{c.name}"\nsize = {toml_list([c.width, c.height])}\nmatrix = {matrix}\n'
            f"distortions = {toml_list(c.dist[:4])}\nrotation = {toml_list(rodrigues(c.R))}\n"
            f"translation = {toml_list(c.t / 1000)}\nfisheye = false\n\n"
        )
    return text + "[metadata]\nadjusted = false\nerror = 0.0\n"


def anipose_toml(cameras: list[Camera]) -> str:
    """Aniposelib's CameraGroup.dump: [cam_0]..., integer sizes, 5 distortions, mm, the toml
    package's trailing commas, a metadata table."""
    text = ""
    for i, c in enumerate(cameras):
        matrix = "[ " + ", ".join(toml_list(row, True) for row in c.K) + ",]"
        text += (
            f'[cam_{i}]\nname = "{c.name}"\nsize = [ {c.width}, {c.height},]\nmatrix = {matrix}\n'
            f"distortions = {toml_list(c.dist, True)}\nrotation = {toml_list(rodrigues(c.R), True)}\n"
            f"translation = {toml_list(c.t, True)}\n\n"
        )
    return text + "[metadata]\nadjusted = true\nerror = 0.31\n"


def test_opencv_yaml_round_trip(tmp_path, rig, caplog):
    path = write_opencv_yaml(tmp_path / "calibration.yml", rig)
    assert path.read_text().startswith("%YAML")
    assert [p.name for p in tmp_path.iterdir()] == ["calibration.yml"]  # no temporary left
    with caplog.at_level(logging.INFO):
        calibration = read_calibration(path)
    assert_same_cameras(calibration.cameras, rig)
    assert (calibration.units, calibration.units_reason) == ("mm", "stated in the file")
    assert f"calibration file {path}: units mm (stated in the file)" in caplog.text
    picked = read_calibration(path, cameras=["BW1", "C1"]).cameras
    assert_same_cameras(picked, [rig[2], rig[0]])
    assert_same_cameras(read_calibration(path, cameras="C2").cameras, [rig[1]])


def test_opencv_5_yaml_header_and_filestorage_json(tmp_path, rig):
    """OpenCV 5 writes ``%YAML 1.2``; FileStorage JSON is told from mmocap's JSON by its keys."""
    text = write_opencv_yaml(tmp_path / "calibration.yml", rig).read_text()
    assert text.startswith("%YAML:1.0\n")
    (tmp_path / "v5.yml").write_text(text.replace("%YAML:1.0", "%YAML 1.2", 1))
    assert_same_cameras(read_calibration(tmp_path / "v5.yml").cameras, rig)
    storage = cv2.FileStorage(str(tmp_path / "rig.json"), cv2.FILE_STORAGE_WRITE)
    storage.write("names", [c.name for c in rig])
    for c in rig:
        for key, value in (("K", c.K), ("dist", c.dist), ("R", c.R), ("T", c.t), ("W", c.width), ("H", c.height)):
            storage.write(f"{key}_{c.name}", value)
    storage.release()
    calibration = read_calibration(tmp_path / "rig.json")
    assert_same_cameras(calibration.cameras, rig, colour=False)
    assert calibration.format == "OpenCV FileStorage JSON, or mmocap's calibration JSON (one camera, with t_mm)"


def test_opencv_xml_with_rodrigues_and_eight_coefficients(tmp_path, rig, caplog):
    path = xml_with(lambda c: np.r_[c.dist, 0, 0, 0])(tmp_path, rig)
    with caplog.at_level(logging.INFO):
        calibration = read_calibration(path)
    assert_same_cameras(calibration.cameras, rig, colour=False)
    assert all(c.colour for c in calibration.cameras)  # no colour key: colour by default
    assert calibration.units == "mm"
    assert re.search(r"units mm \(detected from camera distances 4\d\d0-4\d\d0 mm\)$", caplog.text.strip())


def test_easymocap_names_layout_in_one_file_and_in_intri_extri(tmp_path, rig):
    def write(path, intrinsics: bool, extrinsics: bool):
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        storage.write("names", [c.name for c in rig])
        for c in rig:
            if intrinsics:
                storage.write(f"K_{c.name}", c.K)
                storage.write(f"dist_{c.name}", c.dist.reshape(1, 5))
                storage.write(f"W_{c.name}", c.width)
                storage.write(f"H_{c.name}", c.height)
            if extrinsics:
                storage.write(f"R_{c.name}", np.array(rodrigues(c.R)).reshape(3, 1))
                storage.write(f"Rot_{c.name}", c.R)
                storage.write(f"T_{c.name}", c.t.reshape(3, 1) / 1000)
        storage.release()

    write(tmp_path / "all.yml", True, True)
    assert_same_cameras(read_calibration(tmp_path / "all.yml", units="m").cameras, rig, colour=False)
    folder = tmp_path / "easymocap"
    folder.mkdir()
    write(folder / "intri.yml", True, False)
    write(folder / "extri.yml", False, True)
    calibration = read_calibration(folder)
    assert_same_cameras(calibration.cameras, rig, colour=False)
    assert calibration.units == "m"
    assert calibration.format.startswith("EasyMocap")


def test_pose2sim_metres_and_anipose_mm_give_the_same_cameras(tmp_path, rig, caplog):
    (tmp_path / "Calib.toml").write_text(pose2sim_toml(rig))
    (tmp_path / "calibration.toml").write_text(anipose_toml(rig))
    with caplog.at_level(logging.INFO):
        pose2sim = read_calibration(tmp_path / "Calib.toml")
        anipose = read_calibration(tmp_path / "calibration.toml")
    assert_same_cameras(pose2sim.cameras, rig, colour=False)
    assert_same_cameras(anipose.cameras, rig, colour=False)
    assert (pose2sim.units, anipose.units) == ("m", "mm")
    lines = [r.getMessage() for r in caplog.records]
    assert re.fullmatch(
        rf"calibration file {re.escape(str(tmp_path))}/Calib.toml: units m \(detected from camera "
        r"distances 4\.\d\d?-4\.\d\d? m\): converted to mm",
        lines[0],
    ), lines[0]
    assert "units mm (detected from camera distances" in lines[1]
    assert "converted" not in lines[1]


def test_explicit_units_are_taken_and_announced(tmp_path, rig, caplog):
    (tmp_path / "calibration.toml").write_text(anipose_toml(rig))
    with caplog.at_level(logging.INFO):
        calibration = read_calibration(tmp_path / "calibration.toml", units="m")
    np.testing.assert_allclose(calibration.cameras[0].t, rig[0].t * 1000)
    assert "units m (as set by calibration units): converted to mm" in caplog.text


def test_a_camera_at_the_origin_is_left_out_of_the_units_detection(tmp_path, rig):
    """Anipose calibrates relative to cam_0, which then stands at the origin."""
    shift = rig[0].centre
    moved = [Camera(c.name, c.K, c.dist, c.R, c.t + c.R @ shift, c.width, c.height) for c in rig]
    (tmp_path / "calibration.toml").write_text(pose2sim_toml(moved))
    calibration = read_calibration(tmp_path / "calibration.toml")
    assert calibration.units == "m"
    np.testing.assert_allclose(calibration.cameras[0].centre, 0, atol=1e-6)


def test_ambiguous_units_are_refused(tmp_path, rig):
    small = [Camera(c.name, c.K, c.dist, c.R, c.t / 30, c.width, c.height) for c in rig]  # about 130 units away
    (tmp_path / "calibration.toml").write_text(anipose_toml(small))
    with pytest.raises(DataError) as error:
        read_calibration(tmp_path / "calibration.toml")
    message = str(error.value)
    assert "\n" not in message
    assert str(tmp_path / "calibration.toml") in message
    assert "cannot tell whether its translations are in mm or m" in message
    assert "set calibration units to mm or m" in message
    assert read_calibration(tmp_path / "calibration.toml", units="mm").units == "mm"


def test_units_contradicting_the_file_or_unknown_are_refused(tmp_path, rig):
    path = write_opencv_yaml(tmp_path / "calibration.yml", rig)
    with pytest.raises(DataError, match=r"states that its translations are in mm, but calibration units is m"):
        read_calibration(path, units="m")
    with pytest.raises(ConfigError, match=r"calibration units must be one of mm, m, auto, got 'cm'"):
        read_calibration(path, units="cm")


def test_folders_of_per_camera_files(tmp_path, rig):
    json_folder = tmp_path / "json"
    json_folder.mkdir()
    for camera in rig:
        camera.save(json_folder / f"{camera.name}.json")
    yml_folder = camera_folder(tmp_path, rig)
    (yml_folder / "BW9.yml").unlink()
    expected = sorted(rig, key=lambda c: c.name)
    from_json = read_calibration(json_folder)
    assert_same_cameras(from_json.cameras, expected)
    assert from_json.units_reason == "stated in the file"
    assert_same_cameras(read_calibration(yml_folder).cameras, expected, colour=False)


#: world points in mm in front of every camera of the rig, inside their images
POINTS_MM = np.array([[0.0, 0.0, 0.0], [300.0, 900.0, -200.0], [-400.0, 1500.0, 500.0], [200.0, -300.0, 800.0]])


def lab_rig(rig: list[Camera], tangential: bool) -> list[Camera]:
    """The rig with fx != fy and every distortion coefficient nonzero (``tangential``: p1 p2
    too, which Vicon's model has not)."""
    p1, p2 = (0.0012, -0.0007) if tangential else (0.0, 0.0)
    cameras = []
    for c in rig:
        K = c.K.copy()
        K[1, 1] *= 0.997
        cameras.append(replace(c, K=K, dist=np.array([-0.21, 0.08, p1, p2, 0.01]), _maps={}))
    return cameras


def assert_same_projections(read: list[Camera], written: list[Camera]):
    """Every read camera projects POINTS_MM within 0.01 px of cv2.projectPoints on the camera
    written, and has its name and image size."""
    assert [c.name for c in read] == [c.name for c in written]
    for got, want in zip(read, written, strict=True):
        expected = cv2.projectPoints(POINTS_MM, cv2.Rodrigues(want.R)[0], want.t, want.K, want.dist)[0].reshape(-1, 2)
        assert np.abs(got.project(POINTS_MM) - expected).max() < 0.01, want.name
        assert (got.width, got.height) == (want.width, want.height)


def test_qtm_and_vicon_files_project_as_the_cameras_written(tmp_path, rig, caplog):
    qtm_rig, vicon_rig = lab_rig(rig, tangential=True), lab_rig(rig, tangential=False)
    qtm = write(tmp_path / "Calib.qca.txt", qtm_calibration_xml(qtm_rig))
    vicon = write(tmp_path / "calibration.xcp", vicon_calibration_xml(vicon_rig))
    with caplog.at_level(logging.INFO):
        from_qtm, from_vicon = read_calibration(qtm), read_calibration(vicon)
    assert_same_projections(from_qtm.cameras, qtm_rig)
    assert_same_projections(from_vicon.cameras, vicon_rig)
    assert (from_qtm.format, from_vicon.format) == ("Qualisys QTM calibration XML", "Vicon calibration XML")
    assert (from_qtm.units, from_qtm.units_reason) == ("mm", "stated in the file")
    assert (from_vicon.units, from_vicon.units_reason) == ("mm", "stated in the file")
    assert f"calibration file {qtm}: units mm (stated in the file)" in caplog.text


#: a QTM export of two cameras, the second inactive: sensor 1920 x 1088, video window 1920 x
#: 1080 from row 4; the first camera at (0, -4000, 1000) mm looks along +y, upright (z up)
QTM_FILE = """<?xml version="1.0" encoding="UTF-8"?>
<calibration source="lab.qtm" created="2024-03-12 10:41:07" qtm-version="2024.1" type="regular" wandLength="601.2">
  <results std-dev="0.41" min-max-diff="0.93"/>
  <cameras>
    <camera active="1" calibrated="true" message="" point-count="5120" avg-residual="0.38" serial="28123"
            model="Miqus Video" viewrotation="0" video_resolution="1080p">
      <fov_marker left="0" top="0" right="1919" bottom="1087"/>
      <fov_marker_max left="0" top="0" right="1919" bottom="1087"/>
      <fov_video left="0" top="4" right="1919" bottom="1083"/>
      <fov_video_max left="0" top="0" right="1919" bottom="1087"/>
      <transform x="0.0" y="-4000.0" z="1000.0" r11="1.0" r12="0.0" r13="0.0" r21="0.0" r22="0.0" r23="1.0"
                 r31="0.0" r32="-1.0" r33="0.0"/>
      <intrinsic focallength="6.2" sensorMinU="0.0" sensorMaxU="122879.0" sensorMinV="0.0" sensorMaxV="69631.0"
                 focalLengthU="115200.0" focalLengthV="115136.0" centerPointU="61472.0" centerPointV="35040.0"
                 skew="0.0" radialDistortion1="-0.05" radialDistortion2="0.1" radialDistortion3="0.01"
                 tangentalDistortion1="0.001" tangentalDistortion2="-0.002"/>
    </camera>
    <camera active="0" calibrated="false" message="" point-count="0" avg-residual="0" serial="28124"
            model="Miqus M3" viewrotation="0"/>
  </cameras>
</calibration>
"""
#: a Vicon export of two cameras: 2107734 stands at (0, -4000, 1000) mm turned a quarter turn
#: about x (looking along +y, z up), 2107735 at (0, 0, -5000) unturned, with VICON_RADIAL only
VICON_FILE = """<?xml version="1.0" encoding="UTF-8" standalone="no" ?>
<Cameras VERSION="1.0">
  <Camera DEVICEID="2107734" USERID="3" NAME="" TYPE="Vue" DISPLAY_TYPE="Vue" PIXEL_ASPECT_RATIO="1.25"
          SENSOR="Vue" SENSOR_SIZE="1920 1080" SKEW="0">
    <ControlFrames/>
    <KeyFrames>
      <KeyFrame FRAME="0" FOCAL_LENGTH="1600" IMAGE_ERROR="0.14" WORLD_ERROR="0.21"
                ORIENTATION="0.70710678118654757 0 0 0.70710678118654757" POSITION="0 -4000 1000"
                PRINCIPAL_POINT="955.5 541.25" VICON_RADIAL2="ThirdOrderRadial 955.5 541.25 -0.12 0.05"/>
    </KeyFrames>
  </Camera>
  <Camera DEVICEID="2107735" USERID="4" TYPE="Vue" PIXEL_ASPECT_RATIO="1" SENSOR_SIZE="1280 720" SKEW="0">
    <KeyFrames>
      <KeyFrame FRAME="0" FOCAL_LENGTH="1000" ORIENTATION="0 0 0 1" POSITION="0 0 -5000"
                PRINCIPAL_POINT="640 360" VICON_RADIAL="-0.1 0.02"/>
    </KeyFrames>
  </Camera>
</Cameras>
"""
#: OpenCV's world-to-camera rotation of a camera looking along +y with z up the image
LOOKING_ALONG_Y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def test_a_qtm_export_reads_as_worked_out_by_hand(tmp_path, caplog):
    path = write(tmp_path / "lab.qca.txt", QTM_FILE)
    with caplog.at_level(logging.INFO):
        (camera,) = read_calibration(path).cameras
    assert (camera.name, camera.width, camera.height) == ("28123", 1920, 1080)
    np.testing.assert_allclose(camera.K, [[1800.0, 0.0, 960.5], [0.0, 1799.0, 543.5], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(camera.dist, [-0.05, 0.1, 0.001, -0.002, 0.01])
    np.testing.assert_allclose(camera.R, LOOKING_ALONG_Y)
    np.testing.assert_allclose(camera.t, [0.0, 1000.0, 4000.0])
    assert f'camera 28124: calibration file {path}: inactive (active="0"): left out' in caplog.text


def test_a_vicon_export_reads_as_worked_out_by_hand(tmp_path, caplog):
    with caplog.at_level(logging.WARNING):
        first, second = read_calibration(write(tmp_path / "lab.xcp", VICON_FILE)).cameras
    assert not caplog.records
    assert (first.name, first.width, first.height) == ("2107734", 1920, 1080)
    np.testing.assert_allclose(first.K, [[1600.0, 0.0, 955.5], [0.0, 1280.0, 541.25], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(first.dist, [-0.12, 0.05, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(first.R, LOOKING_ALONG_Y, atol=1e-15)
    np.testing.assert_allclose(first.t, [0.0, 1000.0, 4000.0], atol=1e-9)
    assert (second.name, second.width, second.height) == ("2107735", 1280, 720)
    np.testing.assert_allclose(second.dist, [-0.1, 0.02, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(second.R, np.eye(3))
    np.testing.assert_allclose(second.t, [0.0, 0.0, 5000.0])


def test_a_vicon_distortion_centre_off_the_principal_point_is_warned_of(tmp_path, caplog):
    path = write(tmp_path / "lab.xcp", VICON_FILE.replace("ThirdOrderRadial 955.5", "ThirdOrderRadial 965.5"))
    with caplog.at_level(logging.WARNING):
        first, _ = read_calibration(path).cameras
    np.testing.assert_allclose(first.K[:2, 2], [955.5, 541.25])
    assert f"camera 2107734: calibration file {path}: the distortion's centre in VICON_RADIAL2 stands 10 px" in (
        caplog.text
    )


def test_a_turned_qtm_camera_is_read_unturned_with_a_warning(tmp_path, caplog):
    path = write(tmp_path / "lab.qca.txt", QTM_FILE.replace('viewrotation="0" video', 'viewrotation="180" video'))
    with caplog.at_level(logging.WARNING):
        (camera,) = read_calibration(path).cameras
    np.testing.assert_allclose(camera.R, LOOKING_ALONG_Y)
    assert f"camera 28123: calibration file {path}: viewrotation 180: read as its sensor sees it" in caplog.text


def test_a_folder_holding_one_rig_file_is_read_as_it(tmp_path, rig):
    """Pose2Sim's layout: calibration/Calib.qca.txt beside the images it was made from."""
    folder = tmp_path / "calibration"
    for sub in ("extrinsics", "intrinsics/int_cam01_img"):
        (folder / sub).mkdir(parents=True)
        (folder / sub / "cam01.png").write_bytes(b"not read")
    write(folder / "Calib.qca.txt", qtm_calibration_xml(rig))
    calibration = read_calibration(folder)
    assert_same_projections(calibration.cameras, rig)
    assert (calibration.source, calibration.format) == (folder, "Qualisys QTM calibration XML")
    write(folder / "C1.json", "{}")
    with pytest.raises(DataError, match="mixes calibration formats"):
        read_calibration(folder)


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def yaml_with(edit):
    """A maker of the round-trip YAML of the rig with ``edit(text) -> text`` applied."""

    def make(folder: Path, rig) -> Path:
        path = write_opencv_yaml(folder / "calibration.yml", rig)
        return write(path, edit(path.read_text()))

    return make


def toml_with(edit):
    """A maker of the anipose TOML of the rig with ``edit(text) -> text`` applied."""
    return lambda folder, rig: write(folder / "calibration.toml", edit(anipose_toml(rig)))


def yaml_matrix(key: str, rows: int, cols: int, data) -> str:
    return (
        f"   {key}: !!opencv-matrix\n      rows: {rows}\n      cols: {cols}\n      dt: d\n"
        f"      data: [ {', '.join(map(str, data))} ]\n"
    )


def matrix_replaced(camera: str, key: str, new: str):
    """An edit replacing ``camera``'s matrix ``key`` by ``new`` (YAML lines, or '')."""

    def edit(text: str) -> str:
        block = re.search(rf"^{camera}:\n(?:   .*\n)*", text, re.M)
        body = re.sub(rf"^   {key}: !!opencv-matrix\n(?:      .*\n)+", new, block.group(0), count=1, flags=re.M)
        return text[: block.start()] + body + text[block.end() :]

    return edit


def xml_with(dist):
    """A maker of an OpenCV XML of the rig, one map per camera, with OpenCV's tutorial names, a
    Rodrigues ``rvec``, and ``dist(camera)`` as distortion coefficients; written by cv2 itself."""

    def make(folder: Path, rig) -> Path:
        path = folder / "rig.xml"
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        storage.write("calibration_time", "today")
        for c in rig:
            storage.startWriteStruct(c.name, cv2.FileNode_MAP)
            for key, value in (
                ("camera_matrix", c.K),
                ("distortion_coefficients", dist(c)),
                ("rvec", cv2.Rodrigues(c.R)[0]),
                ("tvec", c.t),
                ("image_width", c.width),
                ("image_height", c.height),
            ):
                storage.write(key, value)
            storage.endWriteStruct()
        storage.release()
        return path

    return make


def qtm_with(edit):
    """A maker of QTM_FILE with ``edit(text) -> text`` applied."""
    return lambda folder, rig: write(folder / "lab.qca.txt", edit(QTM_FILE))


def vicon_with(edit):
    """A maker of VICON_FILE with ``edit(text) -> text`` applied."""
    return lambda folder, rig: write(folder / "lab.xcp", edit(VICON_FILE))


def camera_folder(folder: Path, cameras: list[Camera]) -> Path:
    """A folder of one YAML per camera of ``cameras`` (top-level keys), and BW9.yml holding none."""
    folder = folder / "calibration"
    folder.mkdir()
    for camera in cameras:
        storage = cv2.FileStorage(str(folder / f"{camera.name}.yml"), cv2.FILE_STORAGE_WRITE)
        for key, value in (
            ("K", camera.K),
            ("D", camera.dist[:4]),
            ("R", camera.R),
            ("T", camera.t),
            ("size", np.array([camera.width, camera.height])),
        ):
            storage.write(key, value)
        storage.release()
    write(folder / "BW9.yml", "%YAML:1.0\n---\ncalibration_time: today\n")
    return folder


BAD_INPUTS = {
    # id: (make(folder, rig) -> the file, cameras=, words the one-line message holds besides the file)
    "missing_K": (
        yaml_with(matrix_replaced("C2", "K", "")),
        None,
        ("camera C2", "lacks the camera matrix", "K, camera_matrix, cameraMatrix"),
    ),
    "K_2x2": (
        yaml_with(matrix_replaced("C1", "K", yaml_matrix("K", 2, 2, [1, 0, 0, 1]))),
        None,
        ("camera C1", "'K' must be 3 x 3 numbers, got shape (2, 2)"),
    ),
    "R_not_a_rotation": (
        yaml_with(matrix_replaced("BW1", "R", yaml_matrix("R", 3, 3, [2, 0, 0, 0, 2, 0, 0, 0, 2]))),
        None,
        ("camera BW1", "'R' is not a rotation matrix"),
    ),
    "t_of_two": (
        yaml_with(matrix_replaced("C1", "t", yaml_matrix("t", 2, 1, [1, 2]))),
        None,
        ("camera C1", "'t' must be 3 numbers, got shape (2, 1)"),
    ),
    "unknown_camera": (
        yaml_with(lambda text: text),
        ["C1", "C9"],
        ("camera C9", "has no camera of that name (it has C1, C2, BW1)"),
    ),
    "unparsable_yaml": (
        yaml_with(lambda text: text.replace("data: [ ", "data: [ [", 1)),
        None,
        ("cannot be read as OpenCV FileStorage", "Parsing error at line"),
    ),
    "unparsable_toml": (toml_with(lambda text: text.replace("]\n", "\n", 1)), None, ("is not valid TOML", "line 1")),
    "nonzero_k4_k6": (
        xml_with(lambda c: np.r_[c.dist, 0.01, 0, 0.002]),
        None,
        ("camera C1", "'distortion_coefficients'", "k4 = 0.01, k6 = 0.002", "CALIB_RATIONAL_MODEL"),
    ),
    "six_coefficients": (
        xml_with(lambda c: np.r_[c.dist, 0]),
        None,
        ("camera C1", "'distortion_coefficients' must be 4, 5, 8, 12 or 14", "got shape (6,)"),
    ),
    "duplicate_names": (
        lambda folder, rig: write(folder / "calibration.toml", anipose_toml([*rig, rig[0]])),
        None,
        ("camera C1", "holds two cameras of that name"),
    ),
    "fisheye": (
        toml_with(lambda text: text.replace("[cam_1]\n", "[cam_1]\nfisheye = true\n")),
        None,
        ("camera C2", "'fisheye' is True", "not supported"),
    ),
    "missing_size": (
        toml_with(lambda text: re.sub(r"size = .*\n", "", text, count=1)),
        None,
        ("camera C1", "lacks the image size", "image_width", "size", "[cam_0]"),
    ),
    "size_of_three": (
        toml_with(lambda text: text.replace("size = [", "size = [ 1,", 1)),
        None,
        ("camera C1", "'size' must be [width, height]"),
    ),
    "no_cameras": (toml_with(lambda text: "[metadata]\nerror = 0.1\n"), None, ("holds no cameras", "metadata")),
    "folder_file_without_camera": (
        lambda folder, rig: camera_folder(folder, rig[:1]),
        None,
        ("calibration file", "BW9.yml holds no camera", "must hold one"),
    ),
    "qtm_unparsable": (qtm_with(lambda text: text[:400]), None, ("is not valid XML", "QTM", "line")),
    "qtm_unknown_encoding": (
        qtm_with(lambda text: text.replace('encoding="UTF-8"', 'encoding="xUTF-8"', 1)),
        None,
        ("is not valid XML", "QTM", "unknown encoding"),
    ),
    "qtm_multi_byte_encoding": (
        qtm_with(lambda text: text.replace('encoding="UTF-8"', 'encoding="UTF-16"', 1)),
        None,
        ("is not valid XML", "QTM"),
    ),
    "qtm_other_root": (
        lambda folder, rig: write(folder / "lab.qca.txt", VICON_FILE),
        None,
        ("root element is <Cameras>, expected <calibration>",),
    ),
    "qtm_without_serial": (
        qtm_with(lambda text: text.replace(' serial="28123"', "")),
        None,
        ("camera #1", "<camera> lacks the attribute 'serial'"),
    ),
    "qtm_without_intrinsic": (
        qtm_with(lambda text: re.sub(r"<intrinsic [^>]*/>", "", text)),
        None,
        ("camera 28123", "lacks the element <intrinsic>"),
    ),
    "qtm_focal_nan": (
        qtm_with(lambda text: text.replace('focalLengthU="115200.0"', 'focalLengthU="nan"')),
        None,
        ("camera 28123", "<intrinsic> attribute 'focalLengthU' must be finite", "'nan'"),
    ),
    "qtm_skew": (
        qtm_with(lambda text: text.replace('skew="0.0"', 'skew="2.5"')),
        None,
        ("camera 28123", "attribute 'skew' is 2.5", "not supported"),
    ),
    "qtm_half_pixel_window": (
        qtm_with(lambda text: text.replace('right="1919" bottom="1083"', 'right="1919.5" bottom="1083"')),
        None,
        ("camera 28123", "'<fov_video> left, right' must be an integer number of pixels", "1920.5"),
    ),
    "qtm_viewrotation_45": (
        qtm_with(lambda text: text.replace('viewrotation="0" video', 'viewrotation="45" video')),
        None,
        ("camera 28123", "attribute 'viewrotation' must be 0, 90, 180 or 270, got '45'"),
    ),
    "qtm_active_yes": (
        qtm_with(lambda text: text.replace('active="0"', 'active="yes"')),
        None,
        ("camera 28124", "attribute 'active' must be 1 or 0, got 'yes'"),
    ),
    "qtm_every_camera_inactive": (
        qtm_with(lambda text: text.replace('active="1"', 'active="0"')),
        None,
        ("holds no cameras", 'looked for <camera active="1">'),
    ),
    "vicon_moving_camera": (
        vicon_with(lambda text: text.replace("<KeyFrame FRAME", '<KeyFrame FRAME="9"/><KeyFrame FRAME', 1)),
        None,
        ("camera 2107734", "2 <KeyFrame>s: a moving camera"),
    ),
    "vicon_no_keyframe": (
        vicon_with(lambda text: re.sub(r"<KeyFrame FRAME=\"0\" FOCAL_LENGTH=\"1000\"[^>]*/>", "", text)),
        None,
        ("camera 2107735", "lacks the element <KeyFrames/KeyFrame>"),
    ),
    "vicon_no_name": (
        vicon_with(lambda text: text.replace('DEVICEID="2107735" USERID="4" ', "")),
        None,
        ("camera #2", "lacks the attributes DEVICEID, USERID, NAME"),
    ),
    "vicon_quaternion_of_norm_2": (
        vicon_with(lambda text: text.replace('ORIENTATION="0 0 0 1"', 'ORIENTATION="0 0 0 2"')),
        None,
        ("camera 2107735", "'ORIENTATION' must be a unit quaternion x y z w, got norm 2"),
    ),
    "vicon_sensor_size_of_one": (
        vicon_with(lambda text: text.replace('SENSOR_SIZE="1280 720"', 'SENSOR_SIZE="1280"')),
        None,
        ("camera 2107735", "'SENSOR_SIZE' must be width height in pixels, got '1280'"),
    ),
    "vicon_aspect_zero": (
        vicon_with(lambda text: text.replace('PIXEL_ASPECT_RATIO="1"', 'PIXEL_ASPECT_RATIO="0"')),
        None,
        ("camera 2107735", "'PIXEL_ASPECT_RATIO' must be > 0"),
    ),
    "vicon_skew": (
        vicon_with(lambda text: text.replace('SKEW="0">\n    <KeyFrames>', 'SKEW="0.5">\n    <KeyFrames>')),
        None,
        ("camera 2107735", "attribute 'SKEW' is 0.5"),
    ),
    "vicon_radial2_of_one_coefficient": (
        vicon_with(lambda text: text.replace("541.25 -0.12 0.05", "541.25 -0.12")),
        None,
        ("camera 2107734", "'VICON_RADIAL2' must be <model> <centre x> <centre y> k1 k2 [k3]"),
    ),
    "vicon_no_distortion": (
        vicon_with(lambda text: text.replace(' VICON_RADIAL="-0.1 0.02"', "")),
        None,
        ("camera 2107735", "lacks the lens distortion", "'VICON_RADIAL2' or 'VICON_RADIAL'"),
    ),
    "not_found": (lambda folder, rig: folder / "nothing.yml", None, ("calibration file not found",)),
    "unknown_suffix": (
        lambda folder, rig: write(folder / "calibration.txt", "1 2 3"),
        None,
        ("unknown format .txt", ".toml"),
    ),
}


@pytest.mark.parametrize("case", list(BAD_INPUTS))
def test_bad_calibration_is_one_line_naming_file_camera_and_key(tmp_path, rig, case):
    make, cameras, words = BAD_INPUTS[case]
    path = make(tmp_path, rig)
    with pytest.raises(DataError) as error:
        read_calibration(path, cameras=cameras)
    message = str(error.value)
    assert "\n" not in message
    assert str(path) in message
    for word in words:
        assert word in message, f"{word!r} not in {message!r}"


def test_writer_refuses_names_filestorage_cannot_hold(tmp_path, rig):
    bad = Camera("2 cams", rig[0].K, rig[0].dist, rig[0].R, rig[0].t, 640, 480)
    with pytest.raises(DataError, match="camera 2 cams: cannot be named"):
        write_opencv_yaml(tmp_path / "calibration.yml", [rig[0], bad])
    with pytest.raises(DataError, match="must end in .yml or .yaml"):
        write_opencv_yaml(tmp_path / "calibration.xml", rig)
    assert not any(tmp_path.iterdir())


# --- files cut short or damaged (Hypothesis: tests/helpers.py damages) -----------------------

#: a small rig whose files the property tests damage (the TOML rig's translations in metres)
SMALL_RIG = camera_rig(["C1", "BW1"], 64, 48, np.random.default_rng(11))


def filestorage_text(suffix: str) -> str:
    """The rig in EasyMocap's ``names`` layout as OpenCV FileStorage writes it (``.xml``, ``.json``)."""
    storage = cv2.FileStorage(f"rig{suffix}", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    storage.write("names", [c.name for c in SMALL_RIG])
    storage.write("units", "mm")
    for c in SMALL_RIG:
        for key, value in (("K", c.K), ("dist", c.dist), ("R", c.R), ("T", c.t), ("W", c.width), ("H", c.height)):
            storage.write(f"{key}_{c.name}", value)
    return storage.releaseAndGetString()


def single_camera_yaml(path: Path) -> None:
    """The rig's first camera in a file of its own, its keys at the top level, the image
    height last (a cut inside that number leaves a file that parses)."""
    c = SMALL_RIG[0]
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key, value in (("units", "mm"), ("K", c.K), ("dist", c.dist), ("R", c.R), ("t", c.t)):
        storage.write(key, value)
    storage.write("image_width", c.width)
    storage.write("image_height", c.height)
    storage.release()


#: file name -> the rig's file in that format, written by mmocap or as the tool writes it
CALIBRATION_FILES = {
    "calibration.yml": lambda path: write_opencv_yaml(path, SMALL_RIG),
    "rig.xml": lambda path: path.write_text(filestorage_text(".xml")),
    "rig.json": lambda path: path.write_text(filestorage_text(".json")),
    "C1.json": lambda path: SMALL_RIG[0].save(path),
    "C1.yml": single_camera_yaml,
    "Calib.toml": lambda path: path.write_text(pose2sim_toml(SMALL_RIG)),
    "Calib.qca.txt": lambda path: path.write_text(qtm_calibration_xml(SMALL_RIG)),
    "rig.xcp": lambda path: path.write_text(vicon_calibration_xml(SMALL_RIG)),
}


def read_rig(path: Path) -> list[Camera]:
    units = "m" if path.suffix == ".toml" else "mm"
    return read_calibration(path, units).cameras


@pytest.fixture(scope="module")
def calibration_files(tmp_path_factory):
    """Per name of :data:`CALIBRATION_FILES`: its path, bytes and cameras as read whole."""
    folder = tmp_path_factory.mktemp("calibrations")
    files = {}
    for name, write in CALIBRATION_FILES.items():
        write(folder / name)
        files[name] = (folder / name, (folder / name).read_bytes(), read_rig(folder / name))
    return files


@pytest.mark.parametrize("name", CALIBRATION_FILES)
@settings(max_examples=60)
@given(data=st.data())
def test_a_damaged_calibration_is_refused_or_read_whole(calibration_files, name, data):
    """A cut file is refused, or is a whole file with its cameras read exactly (a TOML or
    YAML file cut between two cameras: the first ones); a byte changed is refused or read,
    never an error of another kind."""
    path, whole, cameras = calibration_files[name]
    if name.startswith("C1."):
        cameras = cameras[:1]
    damage = data.draw(damages(whole))
    outcome = read_damaged(read_rig, path, damage, whole)
    if damage.kind == "cut" and outcome is not None:
        read = outcome[0]
        assert read, f"{damage}: no camera read"
        assert_same_cameras(read, cameras[: len(read)])
        if len(read) < len(cameras):
            assert name == "Calib.toml", f"{damage}: {len(read)} of {len(cameras)} cameras read from {name}"


@pytest.mark.parametrize("suffix", [".yml", ".xml", ".json"])
def test_a_filestorage_key_given_twice_is_refused(tmp_path, suffix):
    """FileStorage would read the first of the two values; the file is refused instead."""
    text = (
        filestorage_text(suffix) if suffix != ".yml" else write_opencv_yaml(tmp_path / "w.yml", SMALL_RIG).read_text()
    )
    path = tmp_path / f"twice{suffix}"
    if suffix == ".yml":
        path.write_text(text.replace("   image_height: 48\n", "   image_height: 48\n   image_height: 4\n", 1))
        expected = "'image_height' twice in the map C1"
    elif suffix == ".xml":
        path.write_text(text.replace("<units>", "<units>m</units>\n<units>", 1))
        expected = "'units' twice in its top level"
    else:
        path.write_text(text.replace('"units"', '"units": "m",\n    "units"', 1))
        expected = "'units' twice in its top level"
    with pytest.raises(DataError, match=f"twice{suffix} gives the key {expected}; keep one"):
        read_calibration(path)
