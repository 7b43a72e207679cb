"""Checking output paths before a run, writing several files all or none, and reading
input files without blocking."""

from __future__ import annotations

import os
import signal

import pytest

from cell.errors import CellError
from cell.files import StagedFiles, check_output_file, read_input_bytes, signals_held


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


@pytest.fixture
def sigint_default():
    """SIGINT handled as Python sets it up in a foreground process (KeyboardInterrupt): a
    test run started in the background (``make test &``) inherits SIGINT ignored, and Python
    then leaves it so."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def test_signals_held_delivers_a_signal_after_the_block(tmp_path, sigint_default):
    done = []
    with pytest.raises(KeyboardInterrupt), signals_held():
        os.kill(os.getpid(), signal.SIGINT)
        done.append("after the signal, still inside")
    assert done == ["after the signal, still inside"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # put back


def _old_files(tmp_path):
    for name in ("a.json", "b.png"):
        (tmp_path / name).write_text("old")


def test_staged_files_that_fail_leave_every_target_as_it_was(tmp_path):
    _old_files(tmp_path)

    def refuse(_tmp):
        raise CellError("refused")

    with pytest.raises(CellError, match="refused"), StagedFiles() as files:
        files.add(tmp_path / "a.json", b"new")
        files.add(tmp_path / "b.png", b"new", check=refuse)
        files.commit()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.png"]  # no temporaries
    assert {p.read_text() for p in tmp_path.iterdir()} == {"old"}


def test_staged_files_interrupted_between_the_renames_are_all_renamed(tmp_path, monkeypatch,
                                                                      sigint_default):
    _old_files(tmp_path)
    real_replace, renamed = os.replace, []

    def replace(src, dst):  # Ctrl-C arrives right after the first rename
        real_replace(src, dst)
        renamed.append(os.path.basename(dst))
        if len(renamed) == 1:
            os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(KeyboardInterrupt), StagedFiles() as files:
        files.add(tmp_path / "a.json", b"new")
        files.add(tmp_path / "b.png", b"new")
        files.commit()
    assert renamed == ["a.json", "b.png"]  # the signal waited for the last one
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.png"]
    assert {p.read_text() for p in tmp_path.iterdir()} == {"new"}


def test_an_ignored_signal_stays_ignored_through_signals_held():
    """A process that ignores SIGINT (started in the background) still ignores it after
    the block: the held signal goes to the handler it would have reached, none."""
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        done = []
        with signals_held():
            os.kill(os.getpid(), signal.SIGINT)
            done.append("inside")
        done.append("after")
        assert done == ["inside", "after"] and signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, before)


def test_a_failure_inside_signals_held_is_reported_not_the_signal_it_held(sigint_default):
    with pytest.raises(ValueError, match="the real error"), signals_held():
        os.kill(os.getpid(), signal.SIGINT)
        raise ValueError("the real error")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_staged_files_remove_an_earlier_output_with_the_renames_only(tmp_path):
    """An output this run does not make goes at commit, with the new files; not before,
    and not when the block fails (a missing one is no error)."""
    old, new = tmp_path / "detections.png", tmp_path / "report.json"
    old.write_bytes(b"earlier run")

    def refuse(_tmp):
        raise CellError("refused")

    with pytest.raises(CellError, match="refused"), StagedFiles() as files:
        files.add(new, b"{}")
        files.remove(old)
        files.remove(tmp_path / "never.png")
        assert old.exists()
        files.add(tmp_path / "bad", b"x", check=refuse)
    assert old.exists() and not new.exists()
    with StagedFiles() as files:
        files.add(new, b"{}")
        files.remove(old)
        files.remove(tmp_path / "never.png")
        files.commit()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]
