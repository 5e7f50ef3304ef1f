"""Atomic file writes and file locks.

A reader never sees half a file, and a crash never leaves one.

Every writer creates a temporary file in the target's folder (same file system, so the
rename is atomic), writes and flushes it, and renames it over the target with
``os.replace``; on any error the temporary file is removed and the error propagates.
"""
from __future__ import annotations

import contextlib
import fcntl
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO


@contextlib.contextmanager
def atomic_writer(path: str | Path, mode: str = "w", **open_kwargs) -> Iterator[IO]:
    """``with atomic_writer(path) as f: f.write(...)``: ``f`` is a temporary file beside
    ``path`` (whose folder is created), renamed to ``path`` when the block ends without an
    error. ``mode`` is ``"w"`` (text) or ``"wb"`` (bytes)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, mode, **open_kwargs) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_writer(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    return Path(path)


def write_json_atomic(path: str | Path, data) -> Path:
    """Write ``data`` as indented JSON to ``path`` atomically; returns the path."""
    return write_text_atomic(path, json.dumps(data, indent=2))


@contextlib.contextmanager
def exclusive(path: Path | None):
    """Hold an exclusive lock on ``<path>.lock`` (nothing when ``path`` is None), so that
    parallel jobs of a sweep do not render the same sequence at once."""
    if path is None:
        yield
        return
    lock = Path(path).with_name(Path(path).name + ".lock")
    lock.parent.mkdir(parents=True, exist_ok=True)
    with open(lock, "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
