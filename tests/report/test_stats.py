"""`mmocap stats`: its options are checked before the test runs (the test itself is checked
in tests/analysis/test_statistics.py)."""

import pandas as pd
import pytest

from mmocap.errors import ConfigError
from mmocap.io import WriteError
from mmocap.report.stats import output_stem
from tests.helpers import run_cli


@pytest.fixture
def results(tmp_path):
    rows = [(block, name, block + k) for block in range(3) for k, name in enumerate("abc")]
    path = tmp_path / "results.csv"
    pd.DataFrame(rows, columns=["sequence", "algorithm", "mean_marker_error_mm"]).to_csv(path, index=False)
    return path


def test_output_stem_creates_its_folder_and_refuses_a_folder_or_a_file_in_the_way(tmp_path):
    assert output_stem(str(tmp_path / "tables" / "t4")) == tmp_path / "tables" / "t4"
    assert (tmp_path / "tables").is_dir()
    for folder in (str(tmp_path / "tables"), str(tmp_path / "new") + "/"):
        with pytest.raises(ConfigError, match=r"--out .* is a folder; give the stem of the files to write"):
            output_stem(folder)
    (tmp_path / "notes").write_text("")
    with pytest.raises(WriteError, match=rf"{tmp_path / 'notes'} is a file, where a folder is needed"):
        output_stem(str(tmp_path / "notes" / "t4"))


def test_nothing_is_computed_or_printed_when_the_output_cannot_be_written(results, tmp_path, capsys):
    (tmp_path / "notes").write_text("")
    assert run_cli("stats", results, "--block", "sequence", "--out", tmp_path / "notes" / "t4") == 2
    out = capsys.readouterr()
    assert out.out == ""
    assert out.err.startswith(f"mmocap: error: cannot write {tmp_path / 'notes'}")


@pytest.mark.parametrize("alpha", ["0", "1", "-0.1", "nan"])
def test_alpha_outside_0_1_is_named(results, capsys, alpha):
    assert run_cli("stats", results, "--block", "sequence", "--alpha", alpha) == 2
    assert capsys.readouterr().err.startswith("mmocap: error: --alpha must be a number in (0, 1), got ")


def test_a_good_table_with_out_writes_three_files(results, tmp_path, capsys):
    assert run_cli("stats", results, "--block", "sequence", "--out", tmp_path / "t" / "friedman") == 0
    assert sorted(p.name for p in (tmp_path / "t").iterdir()) == ["friedman.csv", "friedman.md", "friedman.tex"]
