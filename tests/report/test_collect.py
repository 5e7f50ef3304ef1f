"""``mmocap collect``: a store's runs.csv and frames.csv."""

import pandas as pd
import pytest

from mmocap.analysis import results
from mmocap.analysis.results import ResultsStore, load_runs
from mmocap.errors import DataError
from mmocap.report.collect import collect
from tests.helpers import compose_config, record_of, run_cli


def test_collect_writes_csv_and_an_empty_store_is_an_error(tmp_path, capsys):
    with pytest.raises(DataError, match=str(tmp_path / "records")):
        load_runs(tmp_path)
    assert run_cli("collect", *[str(tmp_path)]) == 2
    assert "no run records" in capsys.readouterr().err
    ResultsStore(tmp_path).put(record_of(compose_config(), [4.0]))
    runs_csv, frames_csv = collect(tmp_path)
    assert pd.read_csv(runs_csv)["mean_marker_error_mm"].tolist() == [4.0]
    assert pd.read_csv(frames_csv).shape == (1, 4)
    assert run_cli("collect", *[str(tmp_path)]) == 0


def test_collect_refuses_a_store_that_mixes_schemas_naming_a_record_of_each(tmp_path, monkeypatch, capsys):
    store = ResultsStore(tmp_path)
    old = store.put(record_of(compose_config("seed=1"), [4.0]))
    monkeypatch.setattr(results, "SCHEMA", results.SCHEMA + 1)  # a newer mmocap adds a record
    new = store.put(record_of(compose_config("seed=2"), [5.0]))
    assert run_cli("collect", str(tmp_path)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"schema {results.SCHEMA - 1} ({old.name}) and schema {results.SCHEMA} ({new.name})" in err
    assert f"mmocap store migrate {tmp_path}" in err
    assert not (tmp_path / "runs.csv").exists()
