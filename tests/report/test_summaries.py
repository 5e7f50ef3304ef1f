import json

from mmocap.report.summaries import collect
from tests.conftest import run_cli


def test_collect_sorts_runs_by_error(tmp_path, capsys):
    for name, err in (("a", 30.0), ("b", 12.5)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(json.dumps(
            {"optimizer": name, "strategy": "holistic", "mean_marker_error_mm": err}))
    table = collect(tmp_path)
    assert list(table["optimizer"]) == ["b", "a"]
    assert run_cli("summaries", *[str(tmp_path), "--csv", str(tmp_path / "t.csv")]) == 0
    out = capsys.readouterr().out
    assert "| b " in out and out.index("| b ") < out.index("| a ")
    assert (tmp_path / "t.csv").read_text().startswith("optimizer,")


def test_empty_or_missing_folder_is_an_error(tmp_path, capsys):
    assert run_cli("summaries", *[str(tmp_path)]) == 2
    assert run_cli("summaries", *[str(tmp_path / "nope")]) == 2
    assert "no such folder" in capsys.readouterr().err
