"""The corpus's unbroken case: the tiny sequence tracks cleanly, so every failure in the
other cases comes from what that case broke."""

import json

from tests.helpers import mmocap, track_args


def test_the_unbroken_copy_tracks_with_exit_0_and_no_warning(sequence_copy, tmp_path):
    out = tmp_path / "run"
    outcome = mmocap(*track_args(sequence_copy, out))
    assert outcome.code == 0, outcome
    assert "Traceback" not in outcome.stderr, outcome
    assert "mmocap: warning" not in outcome.stderr, outcome
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == 2
    assert summary["mean_marker_error_mm"] < 100
    assert summary["plausibility"] == []  # mean fitness measured: 0.09


def test_the_fault_fixtures_refuse_writes(small_disk, make_read_only, tmp_path):
    import pytest

    with pytest.raises(OSError, match="No space left"):
        (small_disk / "big").write_bytes(b"x" * 400_000)
    folder = tmp_path / "ro"
    folder.mkdir()
    make_read_only(folder)
    with pytest.raises(OSError, match="Permission denied|Read-only"):
        (folder / "f").write_text("x")
