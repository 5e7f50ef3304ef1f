"""Safe file writes (mmocap.io): atomic files, checked images, append-only lines, locks, and
the one-line messages of file-system faults."""

import errno
import json
import os
import shutil
import threading
import time

import cv2
import numpy as np
import pytest

from mmocap import io
from mmocap.errors import DataError, MmocapWarning
from mmocap.io import (
    LockBusyError,
    WriteError,
    append_line,
    atomic_path,
    atomic_writer,
    check_whole_lines,
    check_writable_folder,
    describe_os_error,
    exclusive,
    locked,
    read_csv_table,
    read_json_lines,
    read_json_object,
    read_lines_file,
    write_image,
    write_json_atomic,
    write_text_atomic,
)


def leftovers(folder):
    return sorted(p.name for p in folder.rglob("*.tmp"))


def test_atomic_write_replaces_the_file_with_the_umasks_permissions(tmp_path):
    path = tmp_path / "sub" / "a.json"
    write_json_atomic(path, {"a": 1})
    write_json_atomic(path, {"a": 2})
    assert json.loads(path.read_text()) == {"a": 2}
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask
    assert not leftovers(tmp_path)


def test_an_error_while_writing_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    path = write_text_atomic(tmp_path / "a.txt", "old")
    with pytest.raises(RuntimeError), atomic_writer(path) as f:  # noqa: PT012 - the error comes mid-write
        f.write("half")
        raise RuntimeError("crash")
    assert path.read_text() == "old"
    assert not leftovers(tmp_path)


def test_a_path_written_by_name_appears_only_when_the_block_ends_without_an_error(tmp_path):
    path = write_text_atomic(tmp_path / "a.txt", "old")
    with atomic_path(path) as tmp:
        tmp.write_text("new")
        assert path.read_text() == "old"
    assert path.read_text() == "new"
    assert not leftovers(tmp_path)
    with pytest.raises(RuntimeError), atomic_path(path) as tmp:  # noqa: PT012 - the error comes mid-write
        tmp.write_text("half")
        raise RuntimeError("crash")
    assert path.read_text() == "new"
    assert not leftovers(tmp_path)


def test_a_path_the_block_did_not_write_is_a_write_error_naming_the_target(tmp_path):
    with pytest.raises(WriteError, match="a.mp4: no such file"), atomic_path(tmp_path / "a.mp4"):
        pass
    assert not list(tmp_path.iterdir())


def test_a_write_under_a_file_is_a_write_error_naming_the_file(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(WriteError) as caught:
        write_text_atomic(blocker / "sub" / "a.txt", "x")
    error = caught.value
    assert isinstance(error, OSError)
    assert isinstance(error, DataError)
    assert str(error) == (
        f"cannot write {blocker / 'sub'}: {blocker} is a file, where a folder is needed; "
        "remove or rename that file, or use another path"
    )
    assert not leftovers(tmp_path)


@pytest.mark.parametrize(
    ("code", "tail"),
    [
        (errno.ENOSPC, "the disk is full; free some space on it or write somewhere else"),
        (errno.EROFS, "the file system is read-only; write to a writable folder instead"),
        (errno.EACCES, "permission denied; give yourself access to it (chmod, chown) or use another path"),
        (errno.EIO, "Input/output error; check the path and the disk"),
    ],
    ids=["full", "read-only", "permission", "other"],
)
def test_a_file_system_fault_says_what_is_wrong_and_how_to_fix_it(code, tail):
    exc = OSError(code, os.strerror(code), "/data/out/a.png")
    assert describe_os_error(exc, "write") == f"cannot write /data/out/a.png: {tail}"
    assert describe_os_error(exc) == f"/data/out/a.png: {tail}"
    assert str(WriteError(code, os.strerror(code), "/data/out/a.png")) == f"cannot write /data/out/a.png: {tail}"


def test_an_error_without_a_path_is_given_the_path_written(tmp_path):
    with (
        pytest.raises(WriteError, match=r"cannot write .*x\.bin: the disk is full"),
        atomic_writer(tmp_path / "x.bin", "wb"),
    ):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # as a write to a full disk does
    assert not leftovers(tmp_path)


def test_a_write_found_incomplete_is_put_down_to_a_full_disk_only_when_it_is(tmp_path, monkeypatch):
    path = tmp_path / "a.avi"
    assert str(io.incomplete_write(path, "only 1 of its 3 frames could be read back")) == (
        f"cannot write {path}: only 1 of its 3 frames could be read back; check the path and the disk"
    )
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(io.shutil, "disk_usage", lambda folder: usage._replace(free=4096))
    assert "the disk is full" in str(io.incomplete_write(path, "only 1 of its 3 frames could be read back"))


def test_images_are_written_whole_and_read_back(tmp_path):
    image = np.random.default_rng(0).integers(0, 256, (12, 16, 3), dtype=np.uint8)
    path = write_image(tmp_path / "overlays" / "a.png", image)
    np.testing.assert_array_equal(cv2.imread(str(path)), image)


def test_an_image_opencv_cannot_encode_is_a_data_error_and_no_file(tmp_path):
    with pytest.raises(DataError, match=r"cannot encode .* as \.nope"):
        write_image(tmp_path / "a.nope", np.zeros((4, 4), np.uint8))
    assert list(tmp_path.iterdir()) == []


def test_a_torn_last_line_is_skipped_and_the_next_line_starts_on_its_own(tmp_path):
    path = tmp_path / "progress.jsonl"
    append_line(path, json.dumps({"job": 0}))
    with open(path, "a") as f:
        f.write('{"job": 1, "ra')  # a crash in mid-line
    assert read_json_lines(path) == [{"job": 0}]
    append_line(path, json.dumps({"job": 2}))
    assert read_json_lines(path) == [{"job": 0}, {"job": 2}]
    assert path.read_text().splitlines()[-1] == '{"job": 2}'


def test_blank_lines_and_lines_that_are_not_objects_are_skipped(tmp_path):
    path = tmp_path / "log.jsonl"
    path.write_bytes(b'{"a": 1}\n\n[1, 2]\n\xff\xfe\n{"b": 2}\n')
    assert read_json_lines(path) == [{"a": 1}, {"b": 2}]
    with pytest.raises(ValueError, match="one line"):
        append_line(path, "two\nlines")


def test_a_writable_folder_is_made_and_left_empty(tmp_path):
    folder = check_writable_folder(tmp_path / "a" / "b")
    assert folder.is_dir()
    assert list(folder.iterdir()) == []
    (tmp_path / "file").write_text("")
    with pytest.raises(WriteError, match="is a file, where a folder is needed"):
        check_writable_folder(tmp_path / "file")


def test_a_lock_held_elsewhere_is_refused_naming_its_holder(tmp_path):
    lock = tmp_path / "run" / ".lock"
    with locked(lock), pytest.raises(LockBusyError) as caught, locked(lock, wait=False):
        pass
    assert f"process {os.getpid()}" in caught.value.holder
    assert str(lock) in str(caught.value)
    with locked(lock, wait=False):  # free again
        pass


def test_a_waiting_lock_is_taken_when_its_holder_lets_go(tmp_path):
    lock, held, order = tmp_path / ".lock", threading.Event(), []

    def hold():
        with locked(lock):
            held.set()
            time.sleep(0.3)
            order.append("released")

    thread = threading.Thread(target=hold)
    thread.start()
    held.wait(5)
    with locked(lock, wait=True):
        order.append("taken")
    thread.join()
    assert order == ["released", "taken"]


@pytest.mark.parametrize(
    ("code", "runs"),
    [(errno.EROFS, True), (errno.EACCES, True), (errno.ENOSPC, False)],
    ids=["read-only", "no-permission", "full"],
)
def test_exclusive_runs_without_a_lock_only_where_no_lock_file_can_be_made(tmp_path, monkeypatch, code, runs):
    """A read-only dataset folder can still be read; a full disk is an error."""

    def failing(lock, wait=True):
        raise WriteError(code, os.strerror(code), str(lock))

    monkeypatch.setattr(io, "locked", failing)
    ran = []
    if runs:
        with exclusive(tmp_path / "S1_walking"):
            ran.append(True)
        assert ran == [True]
    else:
        with pytest.raises(WriteError, match="disk is full"), exclusive(tmp_path / "S1_walking"):
            ran.append(True)
        assert ran == []


def test_a_json_object_is_read_and_its_file_named_in_every_error(tmp_path):
    path = tmp_path / "a.json"
    path.write_text('{"x": [1, 2]}')
    assert read_json_object(path) == {"x": [1, 2]}
    for text, problem in (('{"x": ', "is not valid JSON"), ("[1]", "is not a JSON object but list")):
        path.write_text(text)
        with pytest.raises(DataError, match=rf"^{path} {problem}"):
            read_json_object(path)
    path.write_bytes(b"\xff\xfe{}")
    with pytest.raises(DataError, match=rf"^{path} is not valid JSON"):
        read_json_object(path)
    with pytest.raises(DataError, match=rf"^cannot read {tmp_path / 'none.json'}: no such file or folder"):
        read_json_object(tmp_path / "none.json")
    with pytest.raises(DataError, match=rf"^cannot read {tmp_path}: it is a folder"):
        read_json_object(tmp_path)


def test_a_json_object_error_names_the_file_as_told_and_ends_with_the_fix(tmp_path):
    path = tmp_path / "r.json"
    path.write_text('"text"')
    with pytest.raises(
        DataError,
        match=rf"^run record {path} is not a record \(a JSON object\) but str; "
        "delete it$",
    ):
        read_json_object(path, name=f"run record {path}", wanted="a record (a JSON object)", fix="delete it")


def test_a_json_key_given_twice_is_refused_at_any_depth(tmp_path):
    """Python's json keeps the last of two values silently; mmocap's reader refuses the file."""
    path = tmp_path / "sequence.json"
    for text, key in (('{"frames": 60, "frames": 6}', "frames"), ('{"a": {"x": 1, "y": 2, "x": 3}}', "x")):
        path.write_text(text)
        with pytest.raises(DataError, match=rf"^{path} gives the key '{key}' twice in one object; keep one; fix it$"):
            read_json_object(path, fix="fix it")


def test_a_file_of_lines_without_a_last_line_end_is_refused_naming_that_line(tmp_path):
    check_whole_lines(b"", "empty.csv")
    check_whole_lines(b"a,b\n1,2\n", "whole.csv")
    check_whole_lines(b"a,b\r\n1,2\r\n", "windows.csv")
    with pytest.raises(
        DataError,
        match=r"^cut.csv: its last line \(line 3: '3,4'\) has no line end, so the file may be cut short there; "
        "copy or write it again, or, if that line is whole, end the file with a newline$",
    ):
        check_whole_lines(b"a,b\n1,2\n3,4", "cut.csv")
    path = tmp_path / "numbers.txt"
    path.write_bytes(b"1 2\n3 4")
    with pytest.raises(DataError, match=r"^x0 file .*numbers.txt: its last line \(line 2: '3 4'\)"):
        read_lines_file(path, f"x0 file {path}")
    path.write_bytes(b"1 2\n3 \xff\n")
    assert read_lines_file(path) == "1 2\n3 \ufffd\n"
    with pytest.raises(DataError, match=r"^cannot read .*none.txt: no such file or folder"):
        read_lines_file(tmp_path / "none.txt")


def test_a_datasets_file_without_a_last_line_end_is_read_with_a_warning(tmp_path):
    path = tmp_path / "C1.cal"
    path.write_bytes(b"1 2\n3 4")
    with pytest.warns(MmocapWarning, match=r"C1.cal: its last line \(line 2: '3 4'\) has no line end: read as it is; "):
        assert read_lines_file(path, unended="warn") == "1 2\n3 4"


def test_a_csv_table_cut_short_or_with_a_row_longer_than_its_header_is_refused(tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(b"a,b\n1,2\n3,4\n")
    assert read_csv_table(path, ("a", "b"), "rows")["b"].tolist() == [2, 4]
    path.write_bytes(b"a,b\n1,2\n3,")
    with pytest.raises(DataError, match=r"t.csv: its last line \(line 3: '3,'\) has no line end"):
        read_csv_table(path, ("a", "b"), "rows")
    path.write_bytes(b"a,b\n1,2,5\n3,4\n")  # pandas would make column a the index and shift the cells
    with pytest.raises(DataError, match=r"t.csv is not a readable CSV table: line 2 holds more than the header's 2"):
        read_csv_table(path, ("a", "b"), "rows")
