"""The sweep's output folder and its whole-or-absent files.

``--out DIR`` is created when missing. An existing folder may hold only what a sweep
writes there (``results.csv``, ``summary.md``, ``*.png`` and the temporary files of an
interrupted write, which are removed once ``results.csv`` is accepted); one sweep at a time
writes to a folder (:func:`sweep_lock`); one holding
``results.csv`` is continued only with ``--resume``; each file this sweep will write that
is already there must be a plain file (not a folder, a link or a device), checked before
any run. Plots and the summary are
written through a temporary name beside the target, fsynced and renamed into place
(:func:`write_atomic`), so a reader never sees half a file.
"""

from __future__ import annotations

import fcntl
import os
import re
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from cell.files import atomic_write_bytes
from cell.sweep.errors import SweepError
from cell.text import escape

__all__ = ["RESULTS", "prepare_out", "remove_temporaries", "sweep_lock", "write_atomic"]

RESULTS = "results.csv"
_OUTPUT = re.compile(r"results\.csv|summary\.md|[A-Za-z0-9_.-]+\.png")
_TEMP = re.compile(r"\.[^/]+\.tmp")


def prepare_out(arg: str, *, resume: bool, files: tuple[str, ...] = (RESULTS,)) -> Path:
    """The output folder ``arg``, checked and created (see the module docstring); ``files``
    are the names the sweep will write there."""
    shown = f"--out {escape(repr(arg))}"
    if not arg:
        raise SweepError(f"{shown}: empty path; name the output folder")
    path = Path(arg)
    try:
        if path.exists() and not path.is_dir():
            raise SweepError(f"{shown}: exists and is not a folder")
        if path.is_dir():
            entries = os.listdir(path)
            foreign = sorted(e for e in entries if not (_OUTPUT.fullmatch(e) or _TEMP.fullmatch(e)))
            if foreign:
                listed = ", ".join(escape(repr(e)) for e in foreign[:3])
                listed += ", ..." if len(foreign) > 3 else ""
                raise SweepError(f"{shown}: holds entries that are not sweep outputs ({listed}); "
                                 "name a new folder, or one written only by cell sweep")
            if RESULTS in entries and not resume:
                raise SweepError(f"{shown}: holds the results of a sweep; pass --resume to finish "
                                 "it, or name a new folder")
            _check_files(path, [f for f in files if f in entries], files, shown)
        elif path.is_symlink():
            raise SweepError(f"{shown}: a symbolic link to nothing (or a loop); name a folder")
        else:
            path.mkdir(parents=True, exist_ok=True)  # (another sweep may make it meanwhile)
        if not os.access(path, os.W_OK | os.X_OK):
            raise SweepError(f"{shown}: cannot be written (no permission)")
    except OSError as exc:
        raise SweepError(f"{shown}: cannot be used: {escape(exc.strerror or str(exc))}") from None
    return path


@contextmanager
def sweep_lock(path: Path) -> Iterator[None]:
    """Hold the sweep's lock on the output folder ``path`` meanwhile (``fcntl.flock`` on the
    folder itself: no file is made, and the system frees it when the process ends, however
    it ends). A ``SweepError`` when another sweep holds it: two sweeps writing one
    ``results.csv`` ran every run twice and left a file no ``--resume`` would take."""
    shown = f"--out {escape(repr(str(path)))}"
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as exc:
        raise SweepError(f"{shown}: cannot be used: {escape(exc.strerror or str(exc))}") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise SweepError(f"{shown}: another cell sweep is writing there now; wait for it to "
                             "end (then --resume), or name another folder") from None
        except OSError:  # a file system without locks (NFS without its lock daemon): as before
            pass
        yield
    finally:
        os.close(fd)  # (releases the lock)


def remove_temporaries(path: Path) -> None:
    """Remove the temporary files an interrupted write left in the output folder ``path``
    (called once ``results.csv`` has been read back and accepted)."""
    for e in os.listdir(path):
        if _TEMP.fullmatch(e):
            (path / e).unlink(missing_ok=True)


def _kind(mode: int) -> str | None:
    """What a file of ``mode`` is when it is not a plain file; None for a plain file."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    return "a link" if stat.S_ISLNK(mode) else "a device, pipe or socket"


def _check_files(path: Path, present: list[str], files: tuple[str, ...], shown: str) -> None:
    """Refuse the first of ``present`` (names of ``files`` already in ``path``) that is not a
    plain file: the sweep would fail on it after its runs (a folder), or write through it
    (a link)."""
    for name in present:
        kind = _kind(os.lstat(path / name).st_mode)
        if kind is not None:
            raise SweepError(f"{shown}: '{escape(name)}' is {kind}, not a file; the sweep writes "
                             f"{', '.join(files)} there: move it away, or name a new folder")


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file beside it (fsynced, read back,
    renamed: :func:`cell.files.atomic_write_bytes`); a failure is a ``SweepError``."""
    atomic_write_bytes(path, data, error=SweepError)
