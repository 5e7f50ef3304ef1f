"""The run folder (mmocap.run_folder): the summary's one reader and writer."""

import json
import re
from pathlib import Path

import pytest

from mmocap.errors import DataError
from mmocap.run_folder import SUMMARY, Summary, read_summary

#: summary.json of the demo config on a tiny sequence, written by the pipeline before the summary
#: was a dataclass (json.dumps of its dict, indent 2)
EXAMPLE = Path(__file__).parent / "golden" / "data" / "summary.json"


def run_folder(tmp_path, text: str) -> Path:
    (tmp_path / SUMMARY).write_text(text)
    return tmp_path


def test_a_summary_reads_and_writes_back_byte_for_byte(tmp_path):
    text = EXAMPLE.read_text()
    summary = read_summary(run_folder(tmp_path, text))
    assert summary.mean_marker_error_mm == pytest.approx(11.455762665157195)
    assert (summary.frames, summary.dof, summary.fps, summary.action) == (3, 39, 60.0, "walking")
    assert list(summary.to_json()) == list(json.loads(text))  # the keys in the same order
    assert json.dumps(summary.to_json(), indent=2) == text
    out = tmp_path / "again"
    assert summary.write(out).read_text() == text


def test_a_summary_of_an_older_mmocap_reads_its_later_keys_as_none(tmp_path):
    later = (
        "mean_best_fitness",
        "frames_scored",
        "cheap_evaluations_per_frame",
        "foreground_seconds_per_frame",
        "evaluator_choice",
        "body",
        "start",
        "keypoints",
        "plausibility",
        "recoveries",
        "fps",
        "warnings",
    )
    older = {k: v for k, v in json.loads(EXAMPLE.read_text()).items() if k not in later}
    summary = read_summary(run_folder(tmp_path, json.dumps(older)))
    assert all(getattr(summary, key) is None for key in later)
    assert summary.subject == "S1"


def broken(key: str, value) -> str:
    """The example summary with ``key`` set to ``value`` (removed for ``...``)."""
    summary = json.loads(EXAMPLE.read_text())
    if value is ...:
        del summary[key]
    else:
        summary[key] = value
    return json.dumps(summary)


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ('{"frames": ', "is not valid JSON"),
        ("[1, 2]", "is not a run summary (a JSON object) but list"),
        (broken("dof", ...), "lacks dof; it is not the summary of a finished tracking run"),
        (broken("dof", "many"), ": dof is 'many', not an integer"),
        (broken("action", 3), ": action is 3, not text or null"),
        (broken("mean_marker_error_mm", "low"), ": mean_marker_error_mm is 'low', not a number or null"),
        (broken("fps", True), ": fps is True, not a number or null"),
    ],
    ids=["not-json", "not-an-object", "missing-key", "text-integer", "number-text", "text-number", "bool-number"],
)
def test_a_broken_summary_is_one_line_naming_the_file(tmp_path, text, problem):
    path = tmp_path / SUMMARY
    with pytest.raises(DataError, match=rf"^{re.escape(str(path))}:? ?{re.escape(problem)}") as error:
        read_summary(run_folder(tmp_path, text))
    assert "\n" not in str(error.value)


def test_a_folder_without_a_summary_is_not_a_finished_run(tmp_path):
    with pytest.raises(DataError, match=rf"^{re.escape(str(tmp_path / SUMMARY))} is missing: .* no finished run"):
        read_summary(tmp_path)


def test_keys_it_does_not_know_are_left_out():
    summary = Summary.from_json({**json.loads(EXAMPLE.read_text()), "colour": "blue"})
    assert "colour" not in summary.to_json()
