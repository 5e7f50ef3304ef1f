"""Bad calibration files: each stops the run with one line naming the file, the camera and
the key. Every reader builds its cameras through :func:`mmocap.camera.checked_camera`, so
the JSON files of a sequence folder are held to the same checks as HumanEva's ``.cal``.

Before, the JSON reader checked only det(R): a negative focal length and a sheared R with
determinant 1 tracked with exit 0 and errors of hundreds of mm."""

import json

import numpy as np
import pytest

from tests.helpers import assert_clean_error, track_args
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
