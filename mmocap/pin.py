"""What a sweep is pinned to, so that every job of it runs the same: mmocap's code, every
config file its jobs compose from, and the installed plugins and numerical packages.

:func:`take` is recorded once in the sweep's ``sweep.json`` when the sweep first starts in
its folder, and every job, and every later start in that folder, takes it again and refuses
to run when :func:`changes` finds a difference (:mod:`mmocap.sweep`). The config files are
those of Hydra's config search path, given here as ``(schema, path)`` pairs (Hydra's
``hydra.runtime.config_sources``): every ``.yaml`` file under each ``pkg`` package and
``file`` folder. Digests are SHA-256 of the files' bytes, so a pin holds from a wheel (no
git) as from a checkout.
"""

from __future__ import annotations

import hashlib
import importlib.resources
from collections.abc import Iterable, Iterator
from importlib.abc import Traversable
from importlib.metadata import distributions
from pathlib import Path

from mmocap import provenance
from mmocap.registry import GROUPS

#: what makes a result in a source checkout: a change there (uncommitted or untracked) makes it dirty
CHECKOUT_PATHS = ("mmocap", "conf", "plugins", "pyproject.toml")
#: the package's own folder, whose files are the code a job runs
PACKAGE = Path(__file__).resolve().parent
#: folders never searched for code or configs, besides hidden ones (``.git``, a job's ``.hydra``)
SKIPPED_FOLDERS = ("__pycache__",)
#: files that are no config: what Hydra writes into a sweep's folder (a config folder may hold one, ``--config-dir .``)
SKIPPED_FILES = ("multirun.yaml",)
#: how many changed things a message names before it counts the rest
NAMED = 3


def _digest(file: Traversable) -> str:
    return hashlib.sha256(file.read_bytes()).hexdigest()


def _files(folder: Traversable, prefix: str = "") -> Iterator[tuple[str, Traversable]]:
    """``(relative path with '/', file)`` of every file under ``folder``, hidden ones,
    :data:`SKIPPED_FILES` and those in hidden or :data:`SKIPPED_FOLDERS` folders left out."""
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.startswith(".") or entry.name in SKIPPED_FOLDERS or entry.name in SKIPPED_FILES:
            continue
        if entry.is_dir():
            yield from _files(entry, f"{prefix}{entry.name}/")
        elif entry.is_file():
            yield f"{prefix}{entry.name}", entry


def code() -> dict[str, str]:
    """``"mmocap/pipeline.py" -> SHA-256`` of every file of the mmocap package this process
    runs (modules, OpenCL kernels, the body model's assets), the wheel's configs
    (``mmocap/conf``, pinned as configs) left out."""
    return {
        f"{PACKAGE.name}/{name}": _digest(file)
        for name, file in _files(PACKAGE)
        if not name.startswith("conf/") and not name.endswith(".pyc")
    }


def config_folder(schema: str, path: str) -> Traversable | None:
    """The folder of one config source: a ``pkg`` source's package (None if it is not
    installed), a ``file`` source's folder (relative to the working directory, as Hydra
    reads it); None for the others (``structured``: Hydra's ConfigStore, no files)."""
    if schema == "pkg":
        try:
            return importlib.resources.files(path)
        except ModuleNotFoundError:
            return None
    return Path(path) if schema == "file" else None


def configs(sources: Iterable[tuple[str, str]]) -> dict[str, dict[str, str]]:
    """``{"pkg://mmocap.conf": {"optimizer/cmaes.yaml": SHA-256, ...}, ...}``: every
    ``.yaml`` file under each config source ``(schema, path)`` that has files."""
    found = {}
    for schema, path in sources:
        folder = config_folder(schema, path)
        if schema in ("pkg", "file"):
            files = _files(folder) if folder is not None and folder.is_dir() else iter(())
            found[f"{schema}://{path}"] = {name: _digest(file) for name, file in files if name.endswith(".yaml")}
    return found


def plugins() -> dict[str, str]:
    """``{distribution: version}`` of every installed distribution that registers an entry
    point in one of mmocap's groups (:data:`mmocap.registry.GROUPS`), mmocap itself included;
    the first found on ``sys.path`` where one is installed twice, as Python loads it."""
    groups = set(GROUPS.values())
    found: dict[str, str] = {}
    for dist in distributions():  # entry_points.txt read first: only the few plugins' metadata is parsed
        if groups & {ep.group for ep in dist.entry_points}:
            found.setdefault(dist.metadata["Name"], dist.version)
    return dict(sorted(found.items()))


def take(sources: Iterable[tuple[str, str]]) -> dict:
    """The pin of this process with the config sources ``sources`` (``(schema, path)``):
    ``code`` (:func:`code`), ``configs`` (:func:`configs`), ``plugins`` (:func:`plugins`) and
    ``packages``, the versions of mmocap and the numerical packages
    (:func:`mmocap.provenance.versions`)."""
    return {"code": code(), "configs": configs(sources), "plugins": plugins(), "packages": provenance.versions()}


def dirty_files() -> list[str] | None:
    """The files under :data:`CHECKOUT_PATHS` of the source checkout that differ from its
    commit, untracked ones included; None for an installed wheel, which is never dirty."""
    return provenance.changed_files(CHECKOUT_PATHS)


def _shown(path: Path) -> str:
    """``path`` relative to the working directory when inside it, else absolute."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def config_file(source: str, name: str) -> str:
    """Where the file ``name`` of the config source ``source`` (``"pkg://mmocap.conf"``)
    lies, as a user finds it: ``conf/optimizer/cmaes.yaml`` from a checkout."""
    schema, _, path = source.partition("://")
    folder = config_folder(schema, path)
    return f"{source}/{name}" if folder is None else _shown(Path(str(folder.joinpath(*name.split("/")))))


def _compared(before: dict[str, str], after: dict[str, str], show) -> list[str]:
    """What differs between two ``{name: digest or version}`` maps, each shown by
    ``show(name)``: ``X`` (changed), ``X (new)``, ``X (deleted)``."""
    changed = [show(n) for n in sorted(before.keys() & after.keys()) if before[n] != after[n]]
    changed += [f"{show(n)} (new)" for n in sorted(after.keys() - before.keys())]
    return changed + [f"{show(n)} (deleted)" for n in sorted(before.keys() - after.keys())]


def _versions(kind: str, before: dict[str, str | None], after: dict[str, str | None]) -> list[str]:
    """``plugin mmocap-pycma (0.1.0, now 0.2.0)``, ``plugin x 1.0 (new)``, ``plugin y 1.0 (uninstalled)``."""
    changed = [
        f"{kind} {n} ({before[n]}, now {after[n]})"
        for n in sorted(before.keys() & after.keys())
        if before[n] != after[n]
    ]
    changed += [f"{kind} {n} {after[n]} (new)" for n in sorted(after.keys() - before.keys())]
    return changed + [f"{kind} {n} {before[n]} (uninstalled)" for n in sorted(before.keys() - after.keys())]


def changes(pinned: dict, now: dict) -> list[str]:
    """What differs between the pin ``pinned`` (:func:`take` when the sweep started) and
    ``now``, configs first: ``conf/optimizer/cmaes.yaml``, ``mmocap/pipeline.py (new)``,
    ``plugin mmocap-pycma (0.1.0, now 0.2.0)``, ``package numpy (2.0.2, now 2.1.0)``; empty when
    nothing does."""
    found = []
    for source in sorted(pinned["configs"].keys() | now["configs"].keys()):
        found += _compared(
            pinned["configs"].get(source, {}), now["configs"].get(source, {}), lambda n, s=source: config_file(s, n)
        )
    found += _compared(pinned["code"], now["code"], str)
    found += _versions("plugin", pinned["plugins"], now["plugins"])
    return found + _versions("package", pinned["packages"], now["packages"])


def named(found: list[str]) -> str:
    """The first :data:`NAMED` of ``found`` and how many more: ``a, b, c and 2 more``."""
    shown = ", ".join(found[:NAMED])
    return shown + (f" and {len(found) - NAMED} more" if len(found) > NAMED else "")
