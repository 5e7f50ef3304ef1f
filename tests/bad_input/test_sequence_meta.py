"""Bad ``sequence.json`` files: each stops the run with one line naming the file and the key
(:func:`mmocap.data.sequence.read_meta`)."""

import json

import pytest

from tests.helpers import assert_clean_error, track_args
from tests.helpers import mmocap_in_process as mmocap


def edit(path, change) -> None:
    """``change(meta)`` applied to ``sequence.json`` at ``path`` (it edits ``meta`` in place)."""
    meta = json.loads(path.read_text())
    change(meta)
    path.write_text(json.dumps(meta))


def set_key(key, value):
    return lambda meta: meta.__setitem__(key, value)


KEY_CASES = {
    "frames-text": (set_key("frames", "two"), "frames", "positive integer"),
    "frames-zero": (set_key("frames", 0), "frames", "positive integer"),
    "frames-fractional": (set_key("frames", 1.5), "frames", "positive integer"),
    "fps-negative": (set_key("fps", -60), "fps", "positive number"),
    "fps-text": (set_key("fps", "fast"), "fps", "positive number"),
    "cameras-a-string": (set_key("cameras", "C1"), "cameras", "list"),
    "cameras-repeated": (set_key("cameras", ["C1", "C1"]), "cameras", "distinct"),
    "marker-names-reordered": (lambda m: m["marker_names"].reverse(), "marker_names", "in its order"),
    "subject-a-number": (set_key("subject", 1), "subject", "string"),
    "format-unknown": (set_key("format", "mmocap-sequence/0"), "format", "mmocap-sequence/1"),
}


@pytest.mark.parametrize(("change", "key", "words"), KEY_CASES.values(), ids=KEY_CASES.keys())
def test_a_wrong_value_names_the_file_and_the_key(sequence_copy, tmp_path, change, key, words):
    path = sequence_copy / "sequence.json"
    edit(path, change)
    assert_clean_error(mmocap(*track_args(sequence_copy, tmp_path / "run")), str(path), f"'{key}'", words)


@pytest.mark.parametrize("key", ["format", "subject", "action", "fps", "frames", "cameras", "marker_names", "x0"])
def test_a_missing_key_is_named(sequence_copy, tmp_path, key):
    path = sequence_copy / "sequence.json"
    edit(path, lambda meta: meta.pop(key))
    assert_clean_error(mmocap(*track_args(sequence_copy, tmp_path / "run")), str(path), "lacks the key", key)


FILE_CASES = {
    "truncated": (lambda p: p.write_text(p.read_text()[:100]), "not valid JSON"),
    "not-an-object": (lambda p: p.write_text('["S1", "walking"]'), "JSON object"),
    "empty": (lambda p: p.write_text(""), "not valid JSON"),
    "not-utf8": (lambda p: p.write_bytes(b"\xff\xfe{}"), "not valid JSON"),
}


@pytest.mark.parametrize(("damage", "words"), FILE_CASES.values(), ids=FILE_CASES.keys())
def test_a_damaged_file_is_named(sequence_copy, tmp_path, damage, words):
    path = sequence_copy / "sequence.json"
    damage(path)
    assert_clean_error(mmocap(*track_args(sequence_copy, tmp_path / "run")), str(path), words)


def test_more_frames_than_images_names_the_missing_ones(sequence_copy, tmp_path):
    edit(sequence_copy / "sequence.json", set_key("frames", 3))
    assert_clean_error(
        mmocap(*track_args(sequence_copy, tmp_path / "run")),
        "camera C1",
        "000002.png",
        str(sequence_copy / "sequence.json"),
    )
