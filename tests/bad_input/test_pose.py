"""Bad start poses (``x0`` in ``sequence.json``, the first frame's pose of 51 numbers in mm
and rad): each stops the run with one line naming ``x0`` and the file, before any tracking
(docs/usage.md lists a NaN pose as a one-line error)."""

import json

import pytest

from tests.helpers import assert_clean_error, track_args
from tests.helpers import mmocap_in_process as mmocap


def change_x0(path, change) -> None:
    meta = json.loads(path.read_text())
    meta["x0"] = change(meta["x0"])
    path.write_text(json.dumps(meta))  # json writes NaN and Infinity as Python's reader takes them


def set_entry(index, value):
    return lambda x0: x0[:index] + [value] + x0[index + 1 :]


CASES = {
    "50-numbers": lambda x0: x0[:50],
    "52-numbers": lambda x0: x0 + [0.0],
    "nan": set_entry(7, float("nan")),
    "infinity": set_entry(0, float("inf")),
    "text-entry": set_entry(3, "0.1"),
    "true-entry": set_entry(4, True),
    "nested-list": lambda x0: [x0],
    "null": lambda x0: None,
    "a-number": lambda x0: 0.0,
}


@pytest.mark.parametrize("change", CASES.values(), ids=CASES.keys())
def test_a_bad_start_pose_names_x0_and_the_file(sequence_copy, tmp_path, change):
    path = sequence_copy / "sequence.json"
    change_x0(path, change)
    out = tmp_path / "run"
    assert_clean_error(mmocap(*track_args(sequence_copy, out)), str(path), "'x0'", "51 finite numbers")
    assert not (out / "frames.csv").exists()
