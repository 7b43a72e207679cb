"""Writing output files whole or not at all, and checking output paths before a run.

``atomic_write_bytes`` writes through a temporary file beside the target: written,
flushed, fsynced, read back and checked, renamed over the target, the folder fsynced. A
failure removes the temporary file and leaves the target as it was. ``StagedFiles`` does
the same for several files that belong together: all are written (and checked) before
the first is renamed, and the renames run with Ctrl-C and SIGTERM held off
(``signals_held``), so a failed write or a signal leaves every target as it was, or none
(a rename that fails midway, the disk gone, leaves the files renamed before it new). ``check_output_file``
refuses, before any work is done, a path that cannot become a file.
"""

from __future__ import annotations

import json
import os
import signal
import stat
import tempfile
import threading
import tomllib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from cell.errors import CellError
from cell.text import escape, show

__all__ = ["MAX_TOML_BYTES", "StagedFiles", "atomic_write_bytes", "atomic_write_text",
           "check_output_file", "file_mode", "input_path", "read_input_bytes", "read_json_file",
           "read_toml_file", "signals_held"]

MAX_TOML_BYTES = 1 << 20  # a scenario or sweep file is a page of TOML; more is a wrong file


@contextmanager
def signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM off meanwhile: one that arrives is delivered, to the handler
    it would have reached, when the block ends. For the few renames that must all happen
    or none. (Off the main thread, where no handler can be changed: nothing is held.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    before = {s: signal.signal(s, lambda signum, _frame: caught.append(signum))
              for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in before.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)
    if caught:  # (only when the block succeeded: a failure's own error is what to report)
        signal.raise_signal(caught[0])


class StagedFiles:
    """Files that are written together, whole or not at all (module docstring).

    :meth:`add` writes each to a temporary file beside its target and checks it;
    :meth:`remove` names an output of an earlier run that this one does not make (removed
    with the renames, so the folder never mixes two runs' files); :meth:`commit` renames
    them all into place (``also``, a callable, runs last, still with the signals held: a
    recording's own rename, say); :meth:`discard` removes what was staged and not
    committed. Use it as a context manager: leaving the block discards."""

    def __init__(self) -> None:
        self._staged: list[tuple[str, Path, str]] = []  # (temporary file, target, kind)
        self._stale: list[tuple[Path, str]] = []  # (an old output to remove, kind)

    def __enter__(self) -> StagedFiles:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.discard()

    def add(self, path: str | Path, data: bytes, *, check: Callable[[str], None] | None = None,
            kind: str = "file", error: type[CellError] = CellError) -> None:
        """Stage ``data`` for ``path`` (options as :func:`atomic_write_bytes`)."""
        path = Path(path)
        self._staged.append((_staged(path, data, check=check, kind=kind, error=error), path, kind))

    def remove(self, path: str | Path, *, kind: str = "file") -> None:
        """Remove ``path`` at :meth:`commit`, if it is then a file (a link: the link)."""
        self._stale.append((Path(path), kind))

    def commit(self, *, also: Callable[[], None] | None = None,
               error: type[CellError] = CellError) -> None:
        """Rename every staged file into place and remove the stale ones, then run
        ``also``; signals held meanwhile."""
        with signals_held():
            for tmp, path, kind in self._staged:
                try:
                    os.replace(tmp, path)
                except OSError as exc:
                    raise error(f"cannot write {kind} {escape(repr(str(path)))}: "
                                f"{escape(exc.strerror or str(exc))}") from None
            for path, kind in self._stale:
                try:
                    if path.is_symlink() or path.is_file():
                        path.unlink()
                except OSError as exc:
                    raise error(f"cannot remove the earlier run's {kind} "
                                f"{escape(repr(str(path)))}: "
                                f"{escape(exc.strerror or str(exc))}") from None
            if also is not None:
                also()
        paths = [path for _, path, _ in self._staged] + [path for path, _ in self._stale]
        for folder in {path.parent if str(path.parent) else Path(".") for path in paths}:
            _fsync_dir(folder)
        self._staged, self._stale = [], []

    def discard(self) -> None:
        """Remove the staged files not yet renamed into place."""
        for tmp, *_ in self._staged:
            if os.path.exists(tmp):
                os.unlink(tmp)
        self._staged, self._stale = [], []


def atomic_write_bytes(path: str | Path, data: bytes, *, check: Callable[[str], None] | None = None,
                       kind: str = "file", error: type[CellError] = CellError) -> None:
    """Write ``data`` to ``path`` atomically (see the module docstring); ``check(temporary
    path)`` may raise to refuse what was written. Failures raise ``error`` naming ``kind``
    and the path."""
    path = Path(path)
    tmp = _staged(path, data, check=check, kind=kind, error=error)
    try:
        os.replace(tmp, path)
    except OSError as exc:
        raise error(f"cannot write {kind} {escape(repr(str(path)))}: "
                    f"{escape(exc.strerror or str(exc))}") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    _fsync_dir(path.parent if str(path.parent) else Path("."))


def _staged(path: Path, data: bytes, *, check: Callable[[str], None] | None, kind: str,
            error: type[CellError]) -> str:
    """A temporary file beside ``path`` holding ``data``: written, fsynced, read back and
    checked (``check``); its name. On failure none is left and ``error`` is raised."""
    shown = escape(repr(str(path)))
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{path.name[:100]}.", suffix=".tmp")
    except OSError as exc:
        raise error(f"cannot write {kind} {shown}: {escape(exc.strerror or str(exc))}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            os.chmod(tmp, file_mode())  # as open() would make it, not mkstemp's 0600
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        if Path(tmp).read_bytes() != data:
            raise error(f"{kind} {shown}: the written file reads back differently")
        if check is not None:
            check(tmp)
    except BaseException as exc:
        if os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise error(f"cannot write {kind} {shown}: {escape(exc.strerror or str(exc))}") from None
        raise
    return tmp


def file_mode() -> int:
    """The mode ``open()`` gives a new file here (0o666 less the umask): temporary files
    are made 0o600, and get this before they are renamed into place."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write_text(path: str | Path, text: str, **options) -> None:
    """``atomic_write_bytes`` of ``text`` in UTF-8 (same options)."""
    atomic_write_bytes(path, text.encode("utf-8"), **options)


def _fsync_dir(folder: Path) -> None:
    """Make the rename durable (POSIX); a platform without directory fsync skips it."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def check_output_file(arg: str, option: str, *, error: type[CellError] = CellError) -> Path:
    """The file an option names, checked before the run: not empty, not a folder nor any
    other non-regular file (a device or FIFO would be replaced by the rename), its folder
    exists and is writable. Raises ``error`` naming the option and the path."""
    if not arg:
        raise error(f"{option}: empty path; name a file")
    shown = escape(repr(arg))
    path = Path(arg)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise error(f"{option} {shown}: is a folder; name a file")
    if path.is_symlink() and not path.exists():
        raise error(f"{option} {shown}: a symbolic link to nothing (or a loop); name a file")
    if path.exists() and not path.is_file():
        raise error(f"{option} {shown}: not a regular file (a device, FIFO or socket); name a file")
    if not folder.is_dir():
        raise error(f"{option} {shown}: the folder {escape(repr(str(folder)))} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise error(f"{option} {shown}: no write permission in {escape(repr(str(folder)))}")
    return path


def input_path(arg: str | Path, *, kind: str, error: type[CellError]) -> tuple[Path, str]:
    """``arg`` as a path and as shown in messages (escaped); an empty string raises
    ``error`` (``Path("")`` would silently mean the current folder)."""
    if isinstance(arg, str) and not arg.strip():
        raise error(f"{escape(repr(arg))}: empty path; name a {kind}")
    return Path(arg), escape(str(arg))


def read_input_bytes(path: Path, shown: str, *, kind: str, limit: int,
                     error: type[CellError]) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them, or ``error``
    naming ``shown`` and ``kind`` when it is missing, a folder, a device, FIFO or socket,
    unreadable or larger. The file is opened without blocking, so a FIFO is refused
    rather than waited on."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        raise error(f"{shown}: no such {kind}") from None
    except IsADirectoryError:
        raise error(f"{shown}: is a directory, not a {kind}") from None
    except OSError as exc:
        raise error(f"{shown}: cannot read the {kind}: {escape(exc.strerror or str(exc))}") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        if stat.S_ISDIR(mode):
            raise error(f"{shown}: is a directory, not a {kind}")
        raise error(f"{shown}: not a regular file (a device, FIFO or socket); not a {kind}")
    with os.fdopen(fd, "rb") as f:
        try:
            data = f.read(limit + 1)
        except OSError as exc:
            raise error(f"{shown}: cannot read the {kind}: "
                        f"{escape(exc.strerror or str(exc))}") from None
    if len(data) > limit:
        raise error(f"{shown}: larger than {_size(limit)}; not a {kind}")
    return data


def _size(n: int) -> str:
    return f"{n >> 20} MiB" if n >= 1 << 20 and n % (1 << 20) == 0 else f"{n:,} bytes"


def _read_text(path: Path, shown: str, *, kind: str, limit: int, error: type[CellError],
               advice: str) -> str:
    """The UTF-8 text of ``path`` (a leading byte-order mark dropped): ``read_input_bytes``'
    errors, and one naming the first undecodable byte, ending in ``advice``."""
    data = read_input_bytes(path, shown, kind=kind, limit=limit, error=error)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(f"{shown}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start}); "
                    f"{advice}") from None


def read_toml_file(path: Path, shown: str, *, kind: str, error: type[CellError]) -> dict:
    """The TOML table in ``path`` (UTF-8, a leading byte-order mark dropped), or ``error``
    naming ``shown`` (the path as the user wrote it, escaped) and ``kind`` (``scenario
    file``...) when it is missing, a folder, not a regular file, unreadable, over 1 MiB,
    not UTF-8 or not TOML."""
    text = _read_text(path, shown, kind=kind, limit=MAX_TOML_BYTES, error=error,
                      advice=f"save the {kind} as UTF-8")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{shown}: not valid TOML: {escape(str(exc))}") from None
    except RecursionError:
        raise error(f"{shown}: not valid TOML: arrays or tables nested too deeply") from None
    except ValueError:  # tomllib refuses integers over Python's 4,300-digit conversion limit
        raise error(f"{shown}: not valid TOML: an integer of over 4,300 digits") from None


def read_json_file(path: Path, shown: str, *, kind: str, limit: int, error: type[CellError]) -> object:
    """The JSON value in ``path`` (UTF-8, a leading byte-order mark dropped), or ``error``
    naming ``shown`` and ``kind`` (``camera file``...) when it is missing, a folder, not a
    regular file, unreadable, over ``limit`` bytes, not UTF-8 or not JSON."""
    text = _read_text(path, shown, kind=kind, limit=limit, error=error, advice="expected JSON")
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"{shown}: not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})"
                    ) from None
    except (ValueError, RecursionError) as exc:  # a 5000-digit number, [[[[...]]]] nested too deep
        raise error(f"{shown}: not valid JSON: {show(str(exc))}") from None
