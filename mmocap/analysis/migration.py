"""``mmocap store migrate FOLDER``: bring a results store's records to this mmocap's schema.

A record is named by its run's key (:func:`mmocap.analysis.results.run_key`), a digest of its
config under the key rules of the record's schema (:data:`~mmocap.analysis.results.SCHEMA`).
When the rules change, the records of an older store are under keys this mmocap no longer
gives its runs, and the jobs refuse that store rather than run its runs again. Each record
holds its run's resolved config (``config``), so the migration computes each older record's
key with the current rules and:

- rewrites a record whose key stays, in place (``schema`` and ``key_config`` updated);
- writes a record whose key moves under its new name, then removes the old file: a
  migration stopped midway (killed, a full disk) leaves the old file, or both, never neither,
  and the same command then finishes it (the new record says where it came from: its
  ``migration``, ``{from_schema, from_run_id, at}``);
- refuses, before it changes anything, records that become one run under the new rules (two
  configs that differed only in what the new rules leave out), naming both: nothing is
  dropped silently;
- writes the store's ``store.json`` with the new schema last.

Every write is atomic (a temporary file in ``records/``, then ``os.replace``). ``--dry-run``
lists what would change and changes nothing. Run it while no sweep writes into the store.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

from omegaconf import OmegaConf

from mmocap import provenance
from mmocap.analysis import results
from mmocap.analysis.results import ResultsStore, key_config, record_schema
from mmocap.errors import DataError
from mmocap.io import write_json_atomic

#: what each kind of step does, as the dry run lists it
STEP_TEXTS = {
    "update": "{source}.json: updated in place, its key stays",
    "rename": "{source}.json -> {target}.json: its key moves",
    "finish": "{source}.json: removed, {target}.json is its migrated copy (a stopped migration)",
}


@dataclass(frozen=True)
class Step:
    """One record's change: ``kind`` is ``update`` (rewritten under its name ``source``),
    ``rename`` (written as ``target``, then ``source`` removed) or ``finish`` (an earlier
    migration wrote ``target``: ``source`` is removed)."""

    kind: str
    source: str
    target: str


@dataclass
class Plan:
    """What migrating the store in ``folder`` does: its ``steps`` in the order they run (a
    record moves only to a name that is free by then), out of its ``records``."""

    folder: Path
    records: int
    steps: list[Step] = field(default_factory=list)

    def count(self, kind: str) -> int:
        """How many steps are of ``kind``."""
        return sum(step.kind == kind for step in self.steps)

    def report(self, dry_run: bool) -> str:
        """What the migration did (or, ``dry_run``, would do): the counts, each step too for a
        dry run."""
        current = self.records - self.count("update") - self.count("rename") - self.count("finish")
        if not self.steps:
            return f"{self.folder}: {self.records} records, all of schema {results.SCHEMA}: nothing to migrate"
        lines = [f"  records/{STEP_TEXTS[s.kind].format(source=s.source, target=s.target)}" for s in self.steps]
        verb = "would be" if dry_run else "were"
        head = (
            f"{self.folder}: {self.records} records; to schema {results.SCHEMA} {verb}: "
            f"{self.count('rename')} renamed (key moved), {self.count('update')} updated in place, "
            f"{self.count('finish')} finished (a stopped migration); {current} already of schema {results.SCHEMA}"
        )
        return "\n".join([head, *lines, "dry run: nothing was changed"]) if dry_run else head


def _new_key(record: dict, source: Path) -> str:
    """The key of ``record``'s run under the current rules, from the config it holds."""
    config = record.get("config")
    if not isinstance(config, dict):
        raise DataError(
            f"run record {source} holds no config to compute its key from; delete it (its run runs again) "
            "and migrate again"
        )
    return results.run_key(OmegaConf.create(config))


def _origin(record: dict, run_id: str) -> str:
    """The record a current record was migrated from (itself if it was not)."""
    migration = record.get("migration")
    return str(migration.get("from_run_id", run_id)) if isinstance(migration, dict) else run_id


def plan(folder) -> Plan:
    """What migrating the store ``folder`` does (:class:`Plan`); a DataError, before anything
    changes, for a store without records, a record of a newer schema or without its config,
    and for records that would become one run (naming both)."""
    store = ResultsStore(folder)
    run_ids = store.run_ids()
    if not run_ids:
        raise DataError(f"no run records in {store.records_dir}: is {store.folder} a results store?")
    origins: dict[str, dict[str, str]] = defaultdict(dict)  # new key -> {first name: file} of the records it names
    old = {}  # run_id -> new key, of the records of an older schema
    for run_id in run_ids:
        record, source = store.get(run_id), store.path(run_id)
        if record_schema(record, source) == results.SCHEMA:  # type: ignore[arg-type]  # listed: it exists
            origins[run_id][_origin(record, run_id)] = run_id  # type: ignore[arg-type]
        else:
            old[run_id] = _new_key(record, source)  # type: ignore[arg-type]
            origins[old[run_id]][run_id] = run_id
    for key, named in origins.items():
        if len(named) > 1:
            first, second = sorted(named.values())[:2]
            raise DataError(
                f"records {first}.json and {second}.json in {store.records_dir} are one run under the "
                f"key rules of schema {results.SCHEMA} (key {key}): delete the one not to keep and run "
                f"`mmocap store migrate {store.folder}` again; nothing was changed"
            )
    # a moved record whose new name holds a record of the current schema: that is its copy (one origin each)
    current = set(run_ids) - set(old)
    steps = [Step("update", run_id, key) for run_id, key in old.items() if key == run_id]
    steps += [Step("finish", run_id, key) for run_id, key in old.items() if key != run_id and key in current]
    moves = [Step("rename", run_id, key) for run_id, key in old.items() if key != run_id and key not in current]
    taken = set(run_ids) - {step.source for step in steps if step.kind == "finish"}
    return Plan(store.folder, len(run_ids), steps + _in_order(moves, taken, store))


def _in_order(moves: list[Step], taken: set[str], store: ResultsStore) -> list[Step]:
    """The ``moves`` in an order where each goes to a name free by then (``taken``: the names
    held now); a DataError if some only swap names among themselves."""
    ordered = []
    while moves:
        ready = [move for move in moves if move.target not in taken]
        if not ready:
            names = ", ".join(f"{m.source}.json -> {m.target}.json" for m in moves[:4])
            raise DataError(
                f"records in {store.records_dir} would take each other's names ({names}): move them into "
                f"stores of their own and migrate each; nothing was changed"
            )
        for move in ready:
            taken.discard(move.source)
            taken.add(move.target)
        ordered += ready
        moves = [move for move in moves if move not in ready]
    return ordered


def migrated(record: dict, run_id: str, source: str) -> dict:
    """``record`` (named ``source``) as a record of the current schema named ``run_id``."""
    new = {
        **record,
        "run_id": run_id,
        "schema": results.SCHEMA,
        "key_config": key_config(OmegaConf.create(record["config"])),
        "migration": {"from_schema": record_schema(record, source), "from_run_id": source, "at": provenance.now()},
    }
    if isinstance(record.get("summary"), dict) and "run_id" in record["summary"]:
        new["summary"] = {**record["summary"], "run_id": run_id}
    return new


def remove(path: Path) -> None:
    """Remove a migrated record's old file (one place, so that a test can stop a migration there)."""
    path.unlink(missing_ok=True)


def migrate(folder, dry_run: bool = False) -> Plan:
    """Bring the records of the store ``folder`` to the current schema (see module doc), or
    with ``dry_run`` only find out what that does; returns the :class:`Plan`."""
    todo = plan(folder)
    if dry_run:
        return todo
    store = ResultsStore(folder)
    for step in todo.steps:
        if step.kind != "finish":
            record = store.get(step.source)
            write_json_atomic(store.path(step.target), migrated(record, step.target, step.source))  # type: ignore[arg-type]
        if step.kind != "update":
            remove(store.path(step.source))
    store.set_schema(results.SCHEMA)  # last: until here, the jobs refuse the store
    return todo


def main(argv: list[str], prog: str) -> None:
    """``mmocap store migrate FOLDER [--dry-run]``: migrate a results store, print what it did."""
    parser = argparse.ArgumentParser(prog=prog, description="Keep a results store (records/<run_id>.json).")
    commands = parser.add_subparsers(dest="command", required=True)
    migrate_parser = commands.add_parser(
        "migrate",
        help="rename the records of an older schema to this mmocap's keys",
        description=f"Bring the store's records to schema {results.SCHEMA}: compute each older record's key "
        "from its config with this mmocap's rules and rename it; refuse records that would become one run.",
    )
    migrate_parser.add_argument("folder", type=Path, help="the store: a sweep folder, or results.store")
    migrate_parser.add_argument("--dry-run", action="store_true", help="list what would change; change nothing")
    options = parser.parse_args(argv)
    print(migrate(options.folder, dry_run=options.dry_run).report(options.dry_run))
