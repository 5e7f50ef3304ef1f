"""Safe file writes: atomic files, checked images, append-only lines, and file locks.

The rules every writer in mmocap follows, so that a crash, a full disk or a read-only folder
never leaves a file that looks finished but is not:

- A file appears under its final name only when it is complete. It is written to a
  temporary file beside it (``.<name>.<random>.tmp``: the same file system, so the rename is
  atomic), flushed to disk and renamed over the target with ``os.replace``; on an error the
  temporary file is removed (:func:`atomic_writer`). Only a crash (SIGKILL, power loss) can
  leave a ``.*.tmp`` behind; readers look for final names only, so it is ignored.
- A file written as it goes (a run's per-frame table) is named ``<name>.partial`` until it
  is complete, then renamed to ``<name>`` (:class:`mmocap.stages.accuracy.FrameLog`).
- An append-only file (a sweep's ``progress.jsonl``) takes whole lines, one write each, each
  starting on a line of its own (:func:`append_line`); its readers skip a line that a crash
  or a full disk tore (:func:`read_json_lines`).
- Images are encoded in memory and written atomically (:func:`write_image`): OpenCV's
  ``imwrite`` only returns False when it fails.
- Every failure to write is a :class:`WriteError`, both an ``OSError`` and a
  :class:`~mmocap.errors.DataError`, whose message names the path, what is wrong (the disk
  is full, the file system is read-only, permission denied, a file where a folder should be)
  and how to fix it; the command line prints it as one line and exits with status 2.
- Locks (:func:`locked`, :func:`exclusive`) are advisory ``flock`` locks on a lock file; the
  kernel releases them when their process ends, however it ends.

And the rules of every reader of an input file, so that a file cut short (a copy or a download
that stopped, a full disk) is never read as a whole one:

- A JSON file is whole when it parses (:func:`read_json_object`): a cut one does not. A key
  given twice is refused, not read as its last value.
- A file of lines (CSV, TOML, YAML, lists of numbers) whose last line has no line end may be
  cut inside that line, a number among it shortened (``1234.5`` read as ``12``): it is refused
  with one line naming the file and that line (:func:`check_whole_lines`); a published
  dataset's file (HumanEva-I's ``.cal`` and ``.ofs``) is read as distributed, with a warning
  saying so. A file cut at a line
  end is a shorter file of whole lines; what it lacks is found by the checks of counts against
  the sequence (frames, markers, cameras) that each reader makes.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import io
import json
import logging
import os
import shutil
import socket
import uuid
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import IO

import cv2
import numpy as np
import pandas as pd

from mmocap.errors import DataError, MmocapWarning

log = logging.getLogger(__name__)

#: free space under which a write that failed without saying why is put down to a full disk
NEARLY_FULL_BYTES = 1 << 20
#: errno -> (what is wrong, how to fix it)
_FAULTS: dict[int | None, tuple[str, str]] = {
    errno.ENOSPC: ("the disk is full", "free some space on it or write somewhere else"),
    errno.EDQUOT: ("your disk quota is used up", "free some space or write somewhere else"),
    errno.EROFS: ("the file system is read-only", "write to a writable folder instead"),
    errno.EACCES: ("permission denied", "give yourself access to it (chmod, chown) or use another path"),
    errno.EPERM: ("operation not permitted", "give yourself access to it (chmod, chown) or use another path"),
    errno.EISDIR: ("it is a folder, where a file is needed", "remove or rename the folder, or use another name"),
    errno.ENOENT: ("no such file or folder", "check the path"),
    errno.ENAMETOOLONG: ("the name is too long", "use a shorter path"),
}
#: errnos of a file standing where a folder is needed
_FILE_IN_THE_WAY = (errno.ENOTDIR, errno.EEXIST)
#: errnos of a folder that this process cannot write into
_NOT_WRITABLE = (errno.EROFS, errno.EACCES, errno.EPERM)


def describe_os_error(exc: OSError, action: str | None = None) -> str:
    """One line about a failed file-system call: the path (``exc.filename``), what is wrong and
    how to fix it, led by ``cannot <action>`` when given (``"cannot write out/a.png: the disk
    is full; free some space on it or write somewhere else"``)."""
    path = Path(exc.filename) if exc.filename is not None else None
    if exc.errno in _FILE_IN_THE_WAY and path is not None:
        blocker = next((p for p in reversed([path, *path.parents]) if p.exists() and not p.is_dir()), path)
        problem = f"{blocker} is a file, where a folder is needed"
        fix = "remove or rename that file, or use another path"
    else:
        problem, fix = _FAULTS.get(exc.errno, (exc.strerror or str(exc), "check the path and the disk"))
    lead = f"cannot {action} {path}" if action else str(path)
    return f"{lead}: {problem}; {fix}"


class WriteError(DataError, OSError):
    """A file or folder could not be written. An ``OSError`` (``errno``, ``strerror``, and the
    path as ``filename``), so that code handling OSErrors still does; a DataError, so that
    the command line prints its message, :func:`describe_os_error`, as one line."""

    def __str__(self) -> str:
        return describe_os_error(self, "write")


@contextlib.contextmanager
def writing(path: str | Path, *, rename: bool = False) -> Iterator[None]:
    """Turn an OSError in the block into a :class:`WriteError` naming ``path``, or the folder
    on its way that could not be made. A WriteError from the block keeps its path, unless
    ``rename`` (for writes into a temporary folder, whose paths mean nothing to the user)."""
    path = Path(path)
    try:
        yield
    except OSError as exc:
        if isinstance(exc, WriteError) and not rename:
            raise
        named = Path(exc.filename) if exc.filename is not None else None
        culprit = named if named is not None and named in path.parents else path
        raise WriteError(exc.errno, exc.strerror or str(exc), str(culprit)) from exc


def incomplete_write(path: str | Path, what: str) -> WriteError:
    """The WriteError for ``path`` found incomplete after a writer that reports no errors
    (OpenCV's video writer) wrote it: the disk is full if less than :data:`NEARLY_FULL_BYTES`
    are free there; otherwise ``what`` says what is wrong."""
    path = Path(path)
    if shutil.disk_usage(path.parent).free < NEARLY_FULL_BYTES:
        return WriteError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    return WriteError(errno.EIO, what, str(path))


def _temporary_beside(path: Path) -> Path:
    return path.with_name(f".{path.name}.{uuid.uuid4().hex[:12]}.tmp")


@contextlib.contextmanager
def atomic_writer(path: str | Path, mode: str = "w", **open_kwargs) -> Iterator[IO]:
    """Write the file ``path`` whole or not at all:
    in ``with atomic_writer(path) as f: f.write(...)``, ``f`` is a temporary file beside
    ``path`` (whose folder is created), renamed to ``path`` when the block ends without an
    error and removed when it does not. ``mode`` is ``"w"`` (text) or ``"wb"`` (bytes). The
    file gets the permissions of a newly created file (the umask's). A failure to write is
    a :class:`WriteError` naming ``path``."""
    with atomic_path(path) as tmp:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, mode, **open_kwargs) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Write the file ``path`` whole or not at all, through a file name:
    ``with atomic_path(path) as tmp: ...`` is the rename under :func:`atomic_writer`, also for
    writers that take a file name rather than a file (an ffmpeg process). ``tmp`` is a path
    beside ``path`` (whose folder is created) for the block to write; it is flushed to disk and
    renamed to ``path`` when the block ends without an error, removed when it does not. A
    failure to write (the block wrote no ``tmp`` included) is a :class:`WriteError` naming
    ``path``."""
    path = Path(path)
    tmp = None
    with writing(path):
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = _temporary_beside(path)
            yield tmp
            with open(tmp, "rb") as f:
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            if tmp is not None:
                with contextlib.suppress(OSError):
                    tmp.unlink(missing_ok=True)
            raise


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_writer(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    return Path(path)


def write_json_atomic(path: str | Path, data) -> Path:
    """Write ``data`` as indented JSON to ``path`` atomically; returns the path."""
    return write_text_atomic(path, json.dumps(data, indent=2))


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_writer(path, "wb") as f:
        f.write(data)
    return Path(path)


def write_image(path: str | Path, image: np.ndarray) -> Path:
    """Write an 8-bit image ((H, W) grey or (H, W, 3) BGR) in the format of ``path``'s suffix
    (``.png``, ``.jpg``, ...) atomically; returns the path. A WriteError if it cannot be
    written, a DataError if OpenCV cannot encode it."""
    path = Path(path)
    try:
        ok, encoded = cv2.imencode(path.suffix, image)
    except cv2.error:  # no encoder for the suffix, or an image it cannot take
        ok = False
    if not ok:
        raise DataError(
            f"cannot encode a {image.dtype} image of shape {image.shape} as {path.suffix} "
            f"for {path}; use .png for 8-bit images"
        )
    return write_bytes_atomic(path, encoded.tobytes())


def append_line(path: str | Path, line: str) -> None:
    """Append ``line`` (JSON, say; no newline in it) and a newline to ``path`` in one write,
    creating the file if need be. A line torn earlier (by a crash or a full disk) is ended
    first, so that the new line starts on a line of its own."""
    if "\n" in line:
        raise ValueError("append_line takes one line without a newline")
    path = Path(path)
    data = (line + "\n").encode()
    with writing(path):
        fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            size = os.fstat(fd).st_size
            if size and os.pread(fd, 1, size - 1) != b"\n":
                data = b"\n" + data
            if os.write(fd, data) != len(data):  # a short write to a file: the disk filled up
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        finally:
            os.close(fd)


def read_json_lines(path: str | Path) -> list[dict]:
    """The JSON objects of an append-only file, one per line, in order. Blank lines and lines
    that are not a whole JSON object (one torn by a crash or a full disk, or still being
    written) are skipped."""
    records = []
    for raw in Path(path).read_bytes().split(b"\n"):
        text = raw.decode("utf-8", errors="replace").strip()
        if not text:
            continue
        try:
            record = json.loads(text)
        except json.JSONDecodeError:
            continue
        if isinstance(record, dict):
            records.append(record)
    return records


class _RepeatedKeyError(Exception):
    """A JSON object gives ``key`` twice."""

    def __init__(self, key: str):
        self.key = key


def _unique_keys(pairs: list[tuple[str, object]]) -> dict:
    """The object of JSON ``pairs``; :class:`_RepeatedKeyError` when a key comes twice (``json``
    would keep the last silently)."""
    data: dict = {}
    for key, value in pairs:
        if key in data:
            raise _RepeatedKeyError(key)
        data[key] = value
    return data


def read_failure(exc: OSError, name: str) -> str:
    """One line about a file ``name`` that could not be read: what is wrong and how to fix it."""
    problem, how = _FAULTS.get(exc.errno, (exc.strerror or str(exc), "check the path"))
    return f"cannot read {name}: {problem}; {how}"


def check_whole_lines(data: bytes, name: str, *, unended: str = "refuse") -> None:
    """Check that the file of lines ``name``, whose bytes are ``data``, is empty or ends with a
    line end: a last line without one may be cut short, and a number in it shortened.

    ``unended="refuse"`` (a file the user's own tools write) makes such a file a DataError of
    one line naming the file and that line and saying how to fix it; ``"warn"`` (a published
    dataset's file, read as distributed: whether it ends with a line end is not known) reads it
    with an :class:`~mmocap.errors.MmocapWarning` saying so."""
    if not data or data.endswith((b"\n", b"\r")):
        return
    number = data.count(b"\n") + 1
    last = data.rsplit(b"\n", 1)[-1].decode("utf-8", errors="replace")
    where = f"{name}: its last line (line {number}: {last!r:.60}) has no line end"
    if unended == "warn":
        warnings.warn(
            f"{where}: read as it is; if the file was cut short there, its last number may be shortened: "
            "compare it with the dataset's copy",
            MmocapWarning,
            stacklevel=3,
        )
        return
    raise DataError(
        f"{where}, so the file may be cut short there; copy or write it again, or, if that line is whole, "
        "end the file with a newline"
    )


def read_lines_file(path: str | Path, name: str | None = None, errors: str = "replace", unended: str = "refuse") -> str:
    """The text (UTF-8, its undecodable bytes handled as ``errors`` says: ``str.decode``'s
    argument) of the file of lines ``path``, checked to end with a line end
    (:func:`check_whole_lines`, which ``unended`` is passed to); a DataError of one line naming
    it as ``name`` (default: the path) when it cannot be read or may be cut short."""
    path = Path(path)
    name = str(path) if name is None else name
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataError(read_failure(exc, name)) from None
    check_whole_lines(data, name, unended=unended)
    return data.decode("utf-8", errors=errors)


def read_json_object(
    path: str | Path, *, name: str | None = None, wanted: str = "a JSON object", fix: str = ""
) -> dict:
    """The JSON object in the file ``path``: the one reader of every JSON file mmocap reads.

    A DataError of one line when the file cannot be read (an OSError: missing, a folder, no
    permission), is not UTF-8 JSON, or holds something other than an object: it names the
    file as ``name`` (default: the path), says what is wrong (``is not {wanted} but list``
    for a non-object) and ends with ``fix``, how to put it right, when given."""
    path = Path(path)
    name = str(path) if name is None else name
    tail = f"; {fix}" if fix else ""
    try:
        data = json.loads(path.read_text(encoding="utf-8"), object_pairs_hook=_unique_keys)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{name} is not valid JSON ({exc}){tail}") from None
    except _RepeatedKeyError as exc:
        raise DataError(f"{name} gives the key {exc.key!r:.80} twice in one object; keep one{tail}") from None
    except OSError as exc:
        raise DataError(read_failure(exc, name)) from None
    if not isinstance(data, dict):
        raise DataError(f"{name} is not {wanted} but {type(data).__name__}{tail}")
    return data


def check_writable_folder(folder: str | Path) -> Path:
    """Create ``folder`` (and its parents) if need be and write and remove a small file in
    it; returns it. A :class:`WriteError` naming it when that fails: a read-only file
    system, no permission, a full disk, a file in the way."""
    folder = Path(folder)
    with writing(folder):
        folder.mkdir(parents=True, exist_ok=True)
        probe = _temporary_beside(folder / "write-test")
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        try:
            os.write(fd, b"\n")
            os.fsync(fd)
        finally:
            os.close(fd)
            probe.unlink()
    return folder


class LockBusyError(DataError):
    """:func:`locked` was told not to wait, and another process holds the lock: ``lock`` is
    the lock file, ``holder`` says which process holds it."""

    def __init__(self, lock: Path, holder: str):
        super().__init__(f"{lock} is held by {holder}")
        self.lock, self.holder = lock, holder


@contextlib.contextmanager
def locked(lock: str | Path, *, wait: bool = True) -> Iterator[None]:
    """Hold an exclusive lock on the file ``lock`` (created, with its folder, if need be) for
    the block. When another process holds it: wait for it (``wait``, logged), or raise
    :class:`LockBusyError` naming that process. The lock file holds the holder's pid and host."""
    lock = Path(lock)
    with writing(lock):
        lock.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "another process"
            if not wait:
                raise LockBusyError(lock, holder) from None
            log.info("waiting for %s, held by %s", lock, holder)
            fcntl.flock(fd, fcntl.LOCK_EX)
        with writing(lock):
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"process {os.getpid()} on {socket.gethostname()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)  # releases the lock


@contextlib.contextmanager
def exclusive(path: Path | None):
    """Hold an exclusive lock on ``<path>.lock`` (nothing when ``path`` is None), so that
    parallel jobs of a sweep do not render the same sequence at once. Where that lock file
    cannot be made (a read-only file system, no permission) no process can render there
    either, and the block runs without a lock: a read-only sequence can still be read."""
    if path is None:
        yield
        return
    lock = Path(path).with_name(Path(path).name + ".lock")
    with contextlib.ExitStack() as held:
        try:
            held.enter_context(locked(lock))
        except WriteError as exc:
            if exc.errno not in _NOT_WRITABLE:
                raise
        yield


def read_csv_table(path: Path, columns: tuple[str, ...], rows: str, **read_options) -> pd.DataFrame:
    """The CSV table at ``path`` (``pd.read_csv`` with ``read_options``), with a header holding
    ``columns`` (names); a DataError naming the file when it is empty (saying it needs the header and
    ``rows``, e.g. "one row per frame and marker"), unreadable, lacks a column, or may be cut
    short (its last line has no line end: :func:`check_whole_lines`)."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise DataError(read_failure(exc, str(path))) from None
    check_whole_lines(data, str(path))
    try:
        with warnings.catch_warnings():
            # pandas reads a first row longer than the header as an index, shifting its cells: refused
            warnings.simplefilter("error", pd.errors.ParserWarning)
            table = pd.read_csv(io.BytesIO(data), index_col=False, **read_options)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path} is empty; it needs the header {','.join(columns)} and {rows}") from None
    except pd.errors.ParserWarning:
        lines = data.splitlines()
        fields = lines[0].count(b",") + 1
        number = next((n for n, line in enumerate(lines[1:], 2) if line.count(b",") + 1 > fields), None)
        where = "a row" if number is None else f"line {number}"
        raise DataError(
            f"{path} is not a readable CSV table: {where} holds more than the header's {fields} fields"
        ) from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise DataError(f"{path} is not a readable CSV table: {' '.join(str(exc).split())}") from None
    absent = [c for c in columns if c not in table.columns]
    if absent:
        raise DataError(
            f"{path} lacks the column{'s' * (len(absent) > 1)} {', '.join(absent)} (it needs {', '.join(columns)})"
        )
    return table
