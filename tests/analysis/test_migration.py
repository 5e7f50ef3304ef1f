"""``mmocap store migrate``: a store's records renamed when the key rules change.

The records are written by this mmocap; the change of rules is simulated: the next schema
leaves the ``recovery`` settings out of the key, which moves every key.
"""

import json

import pytest
from omegaconf import OmegaConf

from mmocap.analysis import migration, results
from mmocap.analysis.migration import migrate
from mmocap.analysis.results import ResultsStore, load_runs, run_key
from mmocap.errors import DataError
from tests.helpers import compose_config, mmocap_in_process, record_of

SEEDS = (1, 2, 3)


def write_records(folder, *configs) -> ResultsStore:
    """A store in ``folder`` with a record (one frame, error 10 + seed mm) of each config."""
    store = ResultsStore(folder)
    for cfg in configs:
        store.put(record_of(cfg, [10.0 + cfg.seed]))
    return store


def seed_configs():
    return [compose_config(f"seed={seed}") for seed in SEEDS]


def files(store: ResultsStore) -> dict[str, str]:
    """Every file under ``records/``, name -> text."""
    return {path.name: path.read_text() for path in sorted(store.records_dir.iterdir())}


def change_rules(monkeypatch, leave_out: str | None = "recovery") -> None:
    """The next schema, whose key leaves ``leave_out`` out (None: the same keys)."""
    monkeypatch.setattr(results, "SCHEMA", results.SCHEMA + 1)
    if leave_out:
        monkeypatch.setattr(results, "NOT_IN_KEY", (*results.NOT_IN_KEY, leave_out))


def test_a_store_of_the_older_schema_is_renamed_to_the_new_keys(tmp_path, monkeypatch):
    store = write_records(tmp_path, *seed_configs())
    old_ids = store.run_ids()
    change_rules(monkeypatch)
    with pytest.raises(DataError, match="mmocap store migrate"):
        store.check_schema()
    before = files(store)

    dry = migrate(tmp_path, dry_run=True).report(dry_run=True)
    assert files(store) == before
    assert dry.count(".json -> ") == 3
    assert "3 renamed (key moved), 0 updated in place" in dry
    assert dry.endswith("dry run: nothing was changed")

    done = migrate(tmp_path)
    new_ids = sorted(run_key(cfg) for cfg in seed_configs())
    assert set(new_ids).isdisjoint(old_ids)
    assert store.run_ids() == new_ids
    for record in store.records():
        assert record["schema"] == results.SCHEMA
        assert "recovery" not in record["key_config"]
        assert record["migration"]["from_schema"] == results.SCHEMA - 1
        assert record["migration"]["from_run_id"] in old_ids
    assert done.count("rename") == 3
    assert json.loads(store.store_file.read_text()) == {"schema": results.SCHEMA}
    store.check_schema()
    runs, _ = load_runs(tmp_path)
    assert sorted(zip(runs["seed"], runs["mean_marker_error_mm"])) == [(s, 10.0 + s) for s in SEEDS]
    assert sorted(runs["run_id"]) == new_ids

    again = migrate(tmp_path).report(dry_run=False)
    assert again.endswith(f"3 records, all of schema {results.SCHEMA}: nothing to migrate")
    assert store.run_ids() == new_ids


def test_a_migration_stopped_midway_is_finished_by_the_next(tmp_path, monkeypatch):
    store = write_records(tmp_path, *seed_configs())
    change_rules(monkeypatch)
    removed = []

    def killed_at_the_second(path):
        if removed:
            raise KeyboardInterrupt  # as a kill between writing the new record and removing the old
        removed.append(path)
        path.unlink()

    with monkeypatch.context() as patch:
        patch.setattr(migration, "remove", killed_at_the_second)
        with pytest.raises(KeyboardInterrupt):
            migrate(tmp_path)
    assert len(store.run_ids()) == 4  # one moved, one both old and new, one not yet
    with pytest.raises(DataError, match=r"mixes records of schema .*mmocap store migrate"):
        load_runs(tmp_path)
    with pytest.raises(DataError, match="mmocap store migrate"):
        store.check_schema()  # the jobs still refuse it

    done = migrate(tmp_path)
    assert (done.count("finish"), done.count("rename"), done.records) == (1, 1, 4)
    assert store.run_ids() == sorted(run_key(cfg) for cfg in seed_configs())
    assert sorted(r["seed"] for r in store.records()) == list(SEEDS)
    assert [p.name for p in store.records_dir.iterdir() if not p.name.endswith(".json")] == []
    store.check_schema()


def test_records_that_become_one_run_are_refused_naming_both(tmp_path, monkeypatch):
    store = write_records(tmp_path, compose_config("seed=1"), compose_config("seed=1", "recovery.enabled=false"))
    first, second = store.run_ids()
    change_rules(monkeypatch)
    before = files(store)
    with pytest.raises(DataError, match=rf"records {first}.json and {second}.json .* are one run") as refused:
        migrate(tmp_path)
    assert "nothing was changed" in str(refused.value)
    assert files(store) == before
    assert not store.store_file.read_text().endswith(f"{results.SCHEMA}}}")


def test_records_whose_keys_stay_are_updated_in_place(tmp_path, monkeypatch):
    store = write_records(tmp_path, *seed_configs())
    ids = store.run_ids()
    for record in store.records():  # the config a record holds gives its key back
        assert run_key(OmegaConf.create(record["config"])) == record["run_id"]
    change_rules(monkeypatch, leave_out=None)
    done = migrate(tmp_path)
    assert done.count("update") == 3
    assert store.run_ids() == ids
    assert {r["schema"] for r in store.records()} == {results.SCHEMA}


def test_a_record_of_a_newer_schema_is_not_migrated(tmp_path):
    store = write_records(tmp_path, compose_config("seed=1"))
    path = store.path(store.run_ids()[0])
    path.write_text(json.dumps({**json.loads(path.read_text()), "schema": results.SCHEMA + 1}))
    with pytest.raises(DataError, match=rf"{path} is of schema {results.SCHEMA + 1}, newer than"):
        migrate(tmp_path)


def test_the_command_migrates_and_names_a_folder_without_records(tmp_path, monkeypatch):
    write_records(tmp_path / "store", *seed_configs())
    change_rules(monkeypatch)
    dry = mmocap_in_process("store", "migrate", tmp_path / "store", "--dry-run")
    assert dry.code == 0, dry
    assert "dry run: nothing was changed" in dry.stdout
    done = mmocap_in_process("store", "migrate", tmp_path / "store")
    assert done.code == 0, done
    assert "3 renamed" in done.stdout
    empty = mmocap_in_process("store", "migrate", tmp_path / "nothing")
    assert empty.code == 2
    assert empty.stderr.strip() == f"mmocap: error: no run records in {tmp_path / 'nothing' / 'records'}: is " + (
        f"{tmp_path / 'nothing'} a results store?"
    )
