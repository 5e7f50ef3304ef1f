"""Bad ``markers_mm.csv`` files: each stops the run with one line naming the file and the
problem (:meth:`mmocap.data.sequence.Sequence.markers`).

Frames without ground truth are not an error of the file: ``evaluation.missing_markers``
says whether they stop the run (``stop``) or are left out of the marker error with a
recorded warning (``warn``, the default), ``frames_scored`` in ``summary.json`` saying over
how many frames the error is. Before, such frames were NaN and the mean silently left them out.
"""

import json

import pandas as pd
import pytest

from tests.helpers import assert_clean_error, assert_warned, track_args
from tests.helpers import mmocap_in_process as mmocap

HEADER = "frame,marker,x_mm,y_mm,z_mm"


def edit_lines(path, change) -> None:
    """``markers_mm.csv`` at ``path`` rewritten as ``change(lines)`` (the header first)."""
    path.write_text("\n".join(change(path.read_text().splitlines())) + "\n")


def replace_cell(line: int, column: str, value: str):
    """The change of :func:`edit_lines` that sets ``column`` of file line ``line`` (1 = the
    header) to ``value``."""

    def change(lines):
        cells = lines[line - 1].split(",")
        cells[HEADER.split(",").index(column)] = value
        return lines[: line - 1] + [",".join(cells)] + lines[line:]

    return change


CASES = {
    "empty-file": (lambda p: p.write_text(""), ("is empty",)),
    "header-only": (lambda p: p.write_text(HEADER + "\n"), ("holds no rows",)),
    "no-z-column": (lambda p: edit_lines(p, lambda ls: [",".join(l.split(",")[:4]) for l in ls]), ("column z_mm",)),
    "text-coordinate": (lambda p: edit_lines(p, replace_cell(3, "y_mm", "abc")), ("'y_mm'", "line 3")),
    "infinite-coordinate": (lambda p: edit_lines(p, replace_cell(2, "x_mm", "inf")), ("'x_mm'", "line 2")),
    "text-frame": (lambda p: edit_lines(p, replace_cell(4, "frame", "two")), ("'frame'", "line 4")),
    "fractional-frame": (lambda p: edit_lines(p, replace_cell(4, "frame", "0.5")), ("'frame'", "line 4")),
    "frame-out-of-range": (lambda p: edit_lines(p, replace_cell(5, "frame", "7")), ("frame 7", "outside", "line 5")),
    "negative-frame": (lambda p: edit_lines(p, replace_cell(5, "frame", "-1")), ("frame -1", "outside")),
    "unknown-marker": (lambda p: edit_lines(p, replace_cell(6, "marker", "nose")), ("unknown marker", "nose")),
    "duplicate-row": (lambda p: edit_lines(p, lambda ls: ls + [ls[1]]), ("appears 2 times", "lines 2, 32")),
    "ragged-row": (lambda p: edit_lines(p, lambda ls: ls + ["1,head,1,2,3,4,5"]), ("not a readable CSV",)),
}


@pytest.mark.parametrize(("damage", "culprits"), CASES.values(), ids=CASES.keys())
def test_a_bad_marker_file_names_it_and_the_problem(sequence_copy, tmp_path, damage, culprits):
    path = sequence_copy / "markers_mm.csv"
    damage(path)
    out = tmp_path / "run"
    assert_clean_error(mmocap(*track_args(sequence_copy, out)), str(path), *culprits)
    assert not (out / "summary.json").exists()


def drop_frame(path, frame: int) -> None:
    table = pd.read_csv(path)
    table[table["frame"] != frame].to_csv(path, index=False)


def clear_coordinates(path) -> None:
    """Every marker of every frame missing (empty coordinates)."""
    table = pd.read_csv(path)
    table[["x_mm", "y_mm", "z_mm"]] = float("nan")
    table.to_csv(path, index=False)


def run_summary(out) -> dict:
    return json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}


def test_a_missing_frame_is_left_out_of_the_mean_with_a_recorded_warning(sequence_copy, tmp_path):
    """The old silent case: frame 1 has no rows. The mean is frame 0's alone, and the
    summary says it scored 1 of 2 frames."""
    drop_frame(sequence_copy / "markers_mm.csv", 1)
    out = tmp_path / "run"
    outcome = mmocap(*track_args(sequence_copy, out))
    summary = run_summary(out)
    assert_warned(outcome, summary, str(sequence_copy / "markers_mm.csv"), "1 of the 2 tracked frames", "frame 1")
    assert summary["frames"] == 2
    assert summary["frames_scored"] == 1
    frames = pd.read_csv(out / "frames.csv")
    assert frames["marker_error_mm"].isna().tolist() == [False, True]
    assert summary["mean_marker_error_mm"] == pytest.approx(frames["marker_error_mm"][0], abs=1e-3)
    assert "(1 scored)" in outcome.stdout


def test_stop_ends_the_run_naming_the_file_and_the_frames(sequence_copy, tmp_path):
    drop_frame(sequence_copy / "markers_mm.csv", 1)
    out = tmp_path / "run"
    assert_clean_error(
        mmocap(*track_args(sequence_copy, out), "evaluation.missing_markers=stop"),
        str(sequence_copy / "markers_mm.csv"),
        "frame 1",
        "evaluation.missing_markers=warn",
    )
    assert not (out / "summary.json").exists()


def test_no_ground_truth_at_all_gives_null_not_nan(sequence_copy, tmp_path):
    clear_coordinates(sequence_copy / "markers_mm.csv")
    out = tmp_path / "run"
    outcome = mmocap(*track_args(sequence_copy, out))
    summary = run_summary(out)
    assert_warned(outcome, summary, "none of the 2 tracked frames", "null")
    assert summary["frames_scored"] == 0
    assert summary["mean_marker_error_mm"] is None
    assert summary["max_marker_error_mm"] is None
    assert "NaN" not in (out / "summary.json").read_text()
    assert "no ground truth" in outcome.stdout


def test_no_ground_truth_at_all_stops_unless_warned(sequence_copy, tmp_path):
    clear_coordinates(sequence_copy / "markers_mm.csv")
    assert_clean_error(
        mmocap(*track_args(sequence_copy, tmp_path / "run"), "evaluation.missing_markers=stop"),
        str(sequence_copy / "markers_mm.csv"),
        "none of the 2 tracked frames",
    )


def test_an_unknown_missing_markers_action_is_a_config_error(sequence_copy, tmp_path):
    assert_clean_error(
        mmocap(*track_args(sequence_copy, tmp_path / "run"), "evaluation.missing_markers=ignore"),
        "evaluation.missing_markers",
        "ignore",
    )


def cut_after(path, rows: int, extra: int = 0) -> None:
    """``markers_mm.csv`` cut after its first ``rows`` rows (whole, with their line ends), and
    ``extra`` bytes of the next: a copy or download that stopped there."""
    lines = path.read_bytes().splitlines(keepends=True)
    path.write_bytes(b"".join(lines[: rows + 1]) + lines[rows + 1][:extra])


def test_a_marker_file_cut_inside_a_row_is_refused_naming_the_line(sequence_copy, tmp_path):
    """The issue's case: cut inside frame 1's eighth row. Before, the torn row was dropped
    (or a cut number read as another) and frame 1 was scored with 7 of its 15 markers, exit 0."""
    path = sequence_copy / "markers_mm.csv"
    cut_after(path, 15 + 7, extra=12)
    out = tmp_path / "run"
    assert_clean_error(mmocap(*track_args(sequence_copy, out)), str(path), "line 24", "no line end", "cut short")
    assert not (out / "summary.json").exists()


def test_a_frame_with_some_markers_is_warned_of_and_not_scored(sequence_copy, tmp_path):
    """Cut at the end of frame 1's seventh row: frame 1 has 7 of its 15 markers. The warning
    names the frame and the count, summary.json records it, and the mean is frame 0's alone;
    ``score`` scores frame 1 over its 7 markers, ``stop`` ends the run."""
    path = sequence_copy / "markers_mm.csv"
    cut_after(path, 15 + 7)
    out = tmp_path / "run"
    outcome = mmocap(*track_args(sequence_copy, out))
    summary = run_summary(out)
    assert_warned(outcome, summary, str(path), "frame 1 has 7 of 15 markers", "not scored", "missing_markers=score")
    assert (summary["frames"], summary["frames_scored"]) == (2, 1)
    frames = pd.read_csv(out / "frames.csv")
    assert frames["marker_error_mm"].isna().tolist() == [False, True]
    assert summary["mean_marker_error_mm"] == pytest.approx(frames["marker_error_mm"][0], abs=1e-3)

    scored = tmp_path / "scored"
    outcome = mmocap(*track_args(sequence_copy, scored), "evaluation.missing_markers=score")
    summary = run_summary(scored)
    assert_warned(outcome, summary, "frame 1 has 7 of 15 markers", "scored over the markers present")
    assert summary["frames_scored"] == 2

    assert_clean_error(
        mmocap(*track_args(sequence_copy, tmp_path / "stopped"), "evaluation.missing_markers=stop"),
        str(path),
        "frame 1 has 7 of 15 markers",
        "evaluation.missing_markers=warn",
    )
