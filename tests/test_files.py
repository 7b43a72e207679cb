"""Checking output paths before a run, and reading input files without blocking."""

from __future__ import annotations

import os

import pytest

from cell.errors import CellError
from cell.files import check_output_file, read_input_bytes


def test_an_output_path_must_be_able_to_become_a_regular_file(tmp_path):
    assert check_output_file(str(tmp_path / "r.json"), "--report") == tmp_path / "r.json"
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    (tmp_path / "loop1").symlink_to("loop2")
    (tmp_path / "loop2").symlink_to("loop1")
    (tmp_path / "dangling").symlink_to("nowhere/x")
    cases = {str(tmp_path / "loop1"): "a symbolic link to nothing",
             str(tmp_path / "dangling"): "a symbolic link to nothing",
             "": "--report: empty path", str(tmp_path): "is a folder",
             str(fifo): "not a regular file", "/dev/null": "not a regular file",
             str(tmp_path / "no" / "r.json"): "does not exist"}
    for arg, needle in cases.items():
        with pytest.raises(CellError, match=needle):
            check_output_file(arg, "--report")
    assert fifo.exists() and not fifo.is_file()  # left as it was
    assert (tmp_path / "loop1").is_symlink() and (tmp_path / "dangling").is_symlink()


def test_input_bytes_come_from_regular_files_only(tmp_path):
    f = tmp_path / "a.toml"
    f.write_bytes(b"x" * 10)
    assert read_input_bytes(f, "a.toml", kind="scenario file", limit=10, error=CellError) == b"x" * 10
    with pytest.raises(CellError, match=r"^a\.toml: larger than 9 bytes; not a scenario file$"):
        read_input_bytes(f, "a.toml", kind="scenario file", limit=9, error=CellError)
    fifo = tmp_path / "p"
    os.mkfifo(fifo)
    for path, needle in [(fifo, "not a regular file"), (tmp_path, "is a directory"),
                         (tmp_path / "missing", "no such scenario file")]:
        with pytest.raises(CellError, match=needle):
            read_input_bytes(path, "x", kind="scenario file", limit=10, error=CellError)
