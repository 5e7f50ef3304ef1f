import json
import re
from pathlib import Path

import pytest

from mmocap.errors import DataError, MmocapWarning
from mmocap.report.summaries import collect
from tests.helpers import run_cli

#: a complete summary.json, of a run of the demo config on a tiny sequence
SUMMARY_EXAMPLE = Path(__file__).parents[1] / "golden" / "data" / "summary.json"


def summary_text(**changes) -> str:
    """A complete summary.json with the entries ``changes`` replaced."""
    return json.dumps({**json.loads(SUMMARY_EXAMPLE.read_text()), **changes})


def test_collect_sorts_runs_by_error(tmp_path, capsys):
    for name, err in (("a", 30.0), ("b", 12.5)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(
            summary_text(optimizer=name, strategy="holistic", mean_marker_error_mm=err)
        )
    table = collect(tmp_path)
    assert list(table["optimizer"]) == ["b", "a"]
    assert run_cli("summaries", *[str(tmp_path), "--csv", str(tmp_path / "t.csv")]) == 0
    out = capsys.readouterr().out
    assert "| b " in out
    assert out.index("| b ") < out.index("| a ")
    assert (tmp_path / "t.csv").read_text().startswith("optimizer,")


def test_empty_or_missing_folder_is_an_error(tmp_path, capsys):
    assert run_cli("summaries", *[str(tmp_path)]) == 2
    assert run_cli("summaries", *[str(tmp_path / "nope")]) == 2
    assert "no such folder" in capsys.readouterr().err


def test_a_run_without_ground_truth_is_listed_last_with_a_warning(tmp_path):
    for name, err in (("a", None), ("b", 12.5), ("c", 9.0)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(summary_text(optimizer=name, mean_marker_error_mm=err))
    with pytest.warns(MmocapWarning, match=r"1 run\(s\) without ground truth .* listed last: .*/a$"):
        table = collect(tmp_path)
    assert list(table["optimizer"]) == ["c", "b", "a"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            summary_text(optimizer="x", mean_marker_error_mm="low"),
            "mean_marker_error_mm is 'low', not a number or null",
        ),
        (summary_text(optimizer="x", max_marker_error_mm=[1]), "max_marker_error_mm is [1], not a number or null"),
        ("[1]", "is not a run summary"),
        ('{"optimizer": ', "is not valid JSON"),
    ],
)
def test_a_broken_summary_names_its_file(tmp_path, text, message):
    (tmp_path / "r").mkdir()
    (tmp_path / "r" / "summary.json").write_text(text)
    path = re.escape(str(tmp_path / "r" / "summary.json"))
    with pytest.raises(DataError, match=rf"^{path}:? .*{re.escape(message)}"):
        collect(tmp_path)
