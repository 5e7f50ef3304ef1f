"""Bad calibration files: each stops the run with one line naming the file, the camera and
the key. Every reader builds its cameras through :func:`mmocap.camera.checked_camera`, so
the JSON files of a sequence folder are held to the same checks as HumanEva's ``.cal``.

Before, the JSON reader checked only det(R): a negative focal length and a sheared R with
determinant 1 tracked with exit 0 and errors of hundreds of mm."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from mmocap.data.calibration import write_opencv_yaml
from mmocap.data.synthetic import camera_rig
from tests.helpers import assert_clean_error, qtm_calibration_xml, track_args, vicon_calibration_xml
from tests.helpers import mmocap_in_process as mmocap


def edit(path, change) -> None:
    """``change(d)`` applied to the calibration JSON ``path`` (it edits ``d`` in place)."""
    d = json.loads(path.read_text())
    change(d)
    path.write_text(json.dumps(d))


def set_key(key, value):
    return lambda d: d.__setitem__(key, value)


def set_item(key, index, value):
    def change(d):
        array = np.asarray(d[key], float)
        array[index] = value
        d[key] = array.tolist()

    return change


SHEAR = [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]  # det 1, not a rotation
REFLECTION = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]  # orthonormal, det -1

CASES = {
    "negative-focal": (set_item("K", (0, 0), -500.0), ("'K'", "focal")),
    "zero-focal": (set_item("K", (1, 1), 0.0), ("'K'", "focal")),
    "sheared-rotation-det-1": (set_key("R", SHEAR), ("'R'", "not a rotation")),
    "reflection-det-minus-1": (set_key("R", REFLECTION), ("'R'", "not a rotation")),
    "K-wrong-shape": (set_key("K", [[500, 0], [0, 500]]), ("'K'", "3 x 3", "(2, 2)")),
    "K-bottom-row-not-001": (set_item("K", (2, 0), 0.5), ("'K'", "[0, 0, 1]")),
    "principal-point-far-outside": (set_item("K", (0, 2), 5000.0), ("'K'", "principal point")),
    "dist-nan": (set_item("dist", 0, float("nan")), ("'dist'", "finite")),
    "dist-four-numbers": (set_key("dist", [0.0, 0.0, 0.0, 0.0]), ("'dist'", "5 numbers")),
    "t-text": (set_key("t_mm", ["a", "b", "c"]), ("'t_mm'", "numbers")),
    "t-infinite": (set_item("t_mm", 2, float("inf")), ("'t_mm'", "finite")),
    "absurd-size-60000x40000": (lambda d: d.update(width=60000, height=40000), ("'width'", "16384")),
    "zero-height": (set_key("height", 0), ("'height'", "16384")),
    "width-text": (set_key("width", "wide"), ("'width'", "integer")),
    "colour-text": (set_key("colour", "false"), ("'colour'", "true or false")),
    "name-of-another-camera": (set_key("name", "C2"), ("'name'", "C2")),
    "missing-key": (lambda d: d.pop("t_mm"), ("lacks", "'t_mm'")),
}


@pytest.mark.parametrize(("change", "culprits"), CASES.values(), ids=CASES.keys())
def test_a_bad_calibration_value_names_file_camera_and_key(sequence_copy, tmp_path, change, culprits):
    path = sequence_copy / "calibration" / "C1.json"
    edit(path, change)
    out = tmp_path / "run"
    assert_clean_error(mmocap(*track_args(sequence_copy, out)), str(path), "camera C1", *culprits)
    assert not (out / "summary.json").exists()  # the old silent run cannot come back


def test_the_sheared_rotation_passed_the_old_determinant_check():
    """The case above is the one the old check (det R = 1 only) let through."""
    assert abs(np.linalg.det(SHEAR) - 1) < 1e-12


FILE_CASES = {
    "missing": (lambda p: p.unlink(), ("not found",)),
    "truncated-json": (lambda p: p.write_text(p.read_text()[:40]), ("not valid JSON",)),
    "not-an-object": (lambda p: p.write_text("[1, 2, 3]"), ("JSON object",)),
    "binary-garbage": (lambda p: p.write_bytes(b"\xff\xfe\x00garbage"), ("not valid JSON",)),
}


@pytest.mark.parametrize(("damage", "culprits"), FILE_CASES.values(), ids=FILE_CASES.keys())
def test_a_bad_calibration_file_names_it_and_the_camera(sequence_copy, tmp_path, damage, culprits):
    path = sequence_copy / "calibration" / "BW1.json"
    damage(path)
    assert_clean_error(mmocap(*track_args(sequence_copy, tmp_path / "run")), str(path), "camera BW1", *culprits)


def lab_file(suffix: str) -> str:
    """A valid QTM (``.qca.txt``) or Vicon (``.xcp``) calibration of cameras C1 and C2."""
    cameras = camera_rig(["C1", "C2"], 160, 120, np.random.default_rng(3))
    return qtm_calibration_xml(cameras) if suffix == ".qca.txt" else vicon_calibration_xml(cameras)


def without(attribute: str, camera: str):
    """An edit removing ``attribute`` from the element of the camera named ``camera``."""

    def edit(text: str) -> str:
        start = text.index(f'"{camera}"')
        block = re.sub(rf' {attribute}="[^"]*"', "", text[start:], count=1)
        return text[:start] + block

    return edit


def replaced(old: str, new: str):
    return lambda text: re.sub(old, new, text, count=1, flags=re.DOTALL)


LAB_CASES = {
    # id: (suffix, edit(text) -> text, what the one line names besides the file)
    "qtm-missing-attribute": (".qca.txt", without("focalLengthU", "C2"), ("camera C2", "'focalLengthU'", "lacks")),
    "qtm-not-a-number": (".qca.txt", replaced(r' y="[^"]*"', ' y="1460,2"'), ("camera C1", "'y'", "number", "1460,2")),
    "qtm-no-cameras": (".qca.txt", replaced(r"<cameras>.*</cameras>", "<cameras/>"), ("holds no cameras",)),
    "qtm-duplicate-serial": (".qca.txt", replaced('serial="C2"', 'serial="C1"'), ("camera C1", "'serial'", "also")),
    "vicon-missing-attribute": (".xcp", without("FOCAL_LENGTH", "C1"), ("camera C1", "'FOCAL_LENGTH'", "lacks")),
    "vicon-not-a-number": (
        ".xcp",
        replaced(r'POSITION="(\S+) ', 'POSITION="4,1e3 '),
        ("camera C1", "'POSITION'", "x y z in mm", "4,1e3"),
    ),
    "vicon-no-cameras": (".xcp", replaced(r"<Camera .*</Camera>\n", ""), ("holds no cameras", "<Camera>")),
    "qtm-cut-mid-file": (".qca.txt", lambda text: text[: len(text) // 2], ("not valid XML", "line")),
    "vicon-cut-mid-file": (".xcp", lambda text: text[: len(text) // 2], ("not valid XML",)),
    "vicon-duplicate-deviceid": (
        ".xcp",
        replaced('DEVICEID="C2"', 'DEVICEID="C1"'),
        ("camera C1", "'DEVICEID'", "also"),
    ),
}


def cut_yaml(path: Path) -> None:
    """The OpenCV YAML ``path`` cut inside the last camera's image height: ``image_height: 1``
    still parses (a 1-pixel-high image), so only the missing line end tells the cut."""
    text = path.read_text()
    path.write_text(text[: text.rindex("image_height: ") + len("image_height: 1")])


def test_a_recording_calibration_cut_inside_a_number_is_refused(tmp_path):
    root = tmp_path / "recording"
    root.mkdir()
    path = write_opencv_yaml(root / "calibration.yml", camera_rig(["C1", "C2"], 160, 120, np.random.default_rng(3)))
    cut_yaml(path)
    assert_clean_error(mmocap("check-recording", str(root)), str(path), "no line end", "cut short", "newline")


@pytest.mark.parametrize(("suffix", "edit", "culprits"), LAB_CASES.values(), ids=LAB_CASES.keys())
def test_a_bad_lab_calibration_names_the_file_and_the_camera(tmp_path, suffix, edit, culprits):
    """QTM's and Vicon's files, in a recording folder as they ship: read before anything else."""
    root = tmp_path / "recording"
    root.mkdir()
    path = root / f"calibration{suffix}"
    text = lab_file(suffix)
    path.write_text(edit(text))
    assert path.read_text() != text  # the edit found what it breaks
    assert_clean_error(mmocap("check-recording", str(root)), str(path), *culprits)
