"""What produced a result: package versions, the source tree's git commit, Python, host,
and the outcome of each OpenCL device's self-check in this process.

:func:`facts` is the dict stored in every run record and sweep file; :func:`line` is the
one-line form written at the top of every table and figure.
"""

from __future__ import annotations

import datetime
import importlib.metadata
import platform
import socket
import subprocess
from functools import lru_cache
from pathlib import Path

PACKAGES = ("mmocap", "numpy", "scipy", "opencv-python-headless", "hydra-core", "pandas", "pyopencl")
_DEVICE_CHECKS: dict[str, str] = {}  # OpenCL device configuration -> its self-check's outcome


def _version(package: str) -> str | None:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return None


@lru_cache(maxsize=1)
def versions() -> dict[str, str | None]:
    """The installed version of each of :data:`PACKAGES` (None where it is not installed)."""
    return {p: _version(p) for p in PACKAGES}


def _git(source: Path, *args) -> str | None:
    try:
        out = subprocess.run(["git", *args], cwd=source, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def record_device_check(device: str, outcome: str) -> None:
    """Note the outcome of the self-check of an OpenCL device configuration ('name (platform),
    local_size k, lanes m'): ``"exact"`` or ``"within tolerance (...)"``."""
    _DEVICE_CHECKS[device] = outcome


def facts() -> dict:
    """git_commit and git_dirty of the source checkout (None when mmocap runs from an
    installed wheel), versions of mmocap and the numerical packages, python, host,
    platform, and opencl_checks: the self-check's outcome per OpenCL device configuration
    an evaluator of this process runs on (see :mod:`mmocap.evaluators.opencl`)."""
    return {**_fixed_facts(), "opencl_checks": dict(_DEVICE_CHECKS)}


def _checkout() -> Path | None:
    """The source checkout mmocap runs from (the folder holding ``pyproject.toml`` and
    ``mmocap/``), None for an installed wheel."""
    source = Path(__file__).resolve().parent.parent
    return source if (source / "pyproject.toml").is_file() and (source / "mmocap").is_dir() else None


def changed_files(paths: tuple[str, ...]) -> list[str] | None:
    """The files under ``paths`` (relative to the source checkout, e.g. ``("mmocap", "conf")``)
    that differ from the checkout's commit, untracked ones included (``git status``), sorted;
    None where mmocap does not run from a git checkout (an installed wheel)."""
    source = _checkout()
    status = None if source is None else _git(source, "status", "--porcelain", "--untracked-files=all", "--", *paths)
    if status is None:
        return None
    return sorted(line.split(maxsplit=1)[1].split(" -> ")[-1].strip('"') for line in status.splitlines())


@lru_cache(maxsize=1)
def _fixed_facts() -> dict:
    source = _checkout()
    commit = _git(source, "rev-parse", "HEAD") if source is not None else None
    dirty = _git(source, "status", "--porcelain", "--untracked-files=no") if source is not None and commit else None
    return {
        "git_commit": commit,
        "git_dirty": None if dirty is None else bool(dirty),
        "versions": versions(),
        "python": platform.python_version(),
        "host": socket.gethostname(),
        "platform": platform.platform(),
    }


def components(used: dict[str, str]) -> dict:
    """Where each component a run used comes from, e.g. ``components({"optimizer": "pycma"})``
    -> ``{"optimizer": {"name": "pycma", "entry_point": "mmocap_pycma.optimizer:Pycma",
    "distribution": "mmocap-pycma", "version": "0.1.0"}}``: the installed package that
    registered it (mmocap itself for the built-ins), None where it is not registered."""
    from mmocap import registry

    found = {}
    for kind, name in used.items():
        ep = registry.available(kind).get(name)
        dist = None if ep is None else ep.dist
        found[kind] = {
            "name": name,
            "entry_point": None if ep is None else ep.value,
            "distribution": None if dist is None else dist.name,
            "version": None if dist is None else dist.version,
        }
    return found


def now() -> str:
    """The current UTC time, ISO 8601."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def line(source: str | Path | None = None) -> str:
    """'mmocap <version> (numpy .., scipy .., pandas ..), commit <hash>[+dirty], <UTC date>,
    source <source>' (unknown parts left out)."""
    known = facts()
    versions = known["versions"]
    parts = [
        f"mmocap {versions.get('mmocap') or 'unknown'} ("
        + ", ".join(f"{p} {versions[p]}" for p in ("numpy", "scipy", "pandas") if versions.get(p))
        + ")"
    ]
    if known["git_commit"]:
        parts.append(f"commit {known['git_commit'][:10]}" + ("+dirty" if known["git_dirty"] else ""))
    parts.append(datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"))
    if source is not None:
        parts.append(f"source {source}")
    return ", ".join(parts)
