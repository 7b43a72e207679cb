"""``results.csv``: one row per finished run, appended as runs finish, read back to resume.

The header is written once, with the file (through a temporary name, so a file is never
half a header). Each row is one line, written in one call, flushed and fsynced before the
next, so an interrupted sweep (Ctrl-C, a killed process, a lost machine) leaves every
finished row and at most one half-written last line. :func:`open_results` reads an
existing file back for ``--resume``: the header must be this sweep's columns, every row a
run of this sweep, none twice, of printable UTF-8 text, its figures (``numbers``) empty or
finite numbers; a last line without its newline that is the start of such a row (or of
the header) is the half-written row of a crash and is cut off (the run is done again).
Anything else (a binary file, a line that is not UTF-8, a control character, a NaN, a row
with the wrong number of fields) is a ``SweepError`` naming the file and line.

Values: empty for None, ``true``/``false``, integers, floats as Python's shortest
round-trip text (never NaN: figures are checked before), lists as JSON.
"""

from __future__ import annotations

import codecs
import contextlib
import csv
import io
import json
import math
import os
import re
from pathlib import Path
from typing import Any

from cell.sweep.errors import SweepError
from cell.text import escape

__all__ = ["Results", "format_value", "open_results", "parse_value", "read_rows"]

_INT = re.compile(r"-?\d{1,20}")
MAX_LINE = 1 << 24  # bytes of one row at most (a row is a few hundred); longer: not a results file


def format_value(value: Any) -> str:
    """A value as CSV text (see the module docstring)."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError("a figure is NaN or infinite")
        return repr(value)
    if isinstance(value, (tuple, list)):
        return json.dumps(list(value), allow_nan=False)
    return str(value)


def parse_value(text: str) -> Any:
    """CSV text back to a value: None, bool, int, finite float, tuple, or the text."""
    if text == "":
        return None
    if text in ("true", "false"):
        return text == "true"
    if _INT.fullmatch(text):
        return int(text)
    if text[:1] == "[":
        try:
            return tuple(json.loads(text, parse_constant=lambda _: None))
        except (ValueError, RecursionError):
            return text
    try:
        number = float(text)
    except ValueError:
        return text
    return number if math.isfinite(number) else None


def _line(values: list[str]) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(values)
    return buf.getvalue()


class Results:
    """An open ``results.csv``: :meth:`append` writes one row durably; ``done`` holds the
    run ids already in the file."""

    def __init__(self, path: Path, columns: tuple[str, ...], done: set[str]) -> None:
        self.path, self.columns, self.done = path, columns, done
        self._file = open(path, "ab")  # noqa: SIM115 (held open for the sweep)

    def append(self, row: dict[str, Any]) -> None:
        """Write ``row`` (column -> value; missing columns are empty) as one line, fsynced."""
        cells = []
        for c in self.columns:
            try:
                cells.append(format_value(row.get(c)))
            except ValueError as exc:  # (the workers turn NaN into an empty cell: a bug)
                raise SweepError(f"{escape(str(self.path))}: run {escape(str(row.get('run_id')))}, "
                                 f"column {c!r}: {exc}") from None
        data = _line(cells).encode("utf-8")
        try:
            self._file.write(data)
            self._file.flush()
            os.fsync(self._file.fileno())
        except OSError as exc:
            raise SweepError(f"cannot write {escape(str(self.path))}: "
                             f"{escape(exc.strerror or str(exc))}") from None
        self.done.add(str(row["run_id"]))

    def close(self) -> None:
        """Close the file. A flush that fails again (a full disk: the error that stopped the
        sweep was already raised) loses only the half row it held, which ``--resume`` drops."""
        with contextlib.suppress(OSError):
            self._file.close()

    def count(self) -> int:
        """Rows in the file now (a half-written last line not counted)."""
        try:
            with open(self.path, "rb") as f:
                return max(0, sum(chunk.count(b"\n") for chunk in iter(lambda: f.read(1 << 20), b"")) - 1)
        except OSError:
            return len(self.done)


def _create(path: Path, columns: tuple[str, ...]) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as f:
        f.write(_line(list(columns)).encode("utf-8"))
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _scan(path: Path, columns: tuple[str, ...], known: set[str],
          numbers: tuple[str, ...]) -> tuple[set[str], int | None]:
    """The run ids in ``path`` and the offset of a half-written last line (None if none)."""
    shown = escape(str(path))
    header = _line(list(columns)).encode("utf-8")
    figures = [i for i, c in enumerate(columns) if c in numbers]
    done: set[str] = set()
    offset = 0
    with open(path, "rb") as f:
        for number, raw in enumerate(iter(lambda: f.readline(MAX_LINE + 1), b""), 1):
            if len(raw) > MAX_LINE:
                raise SweepError(f"{shown}: line {number} is longer than {MAX_LINE >> 20} MiB; "
                                 "not a results file")
            if not raw.endswith(b"\n"):
                _check_half(raw, number, header, known - done, len(columns), shown)
                return done, offset  # a crash's half-written row
            offset += len(raw)
            fields = _fields(raw, number, shown)
            if number == 1:
                if tuple(fields) != columns:
                    raise SweepError(f"{shown}: its columns are not this sweep's (another sweep wrote "
                                     "it, or the sweep file changed its keys or jobs); name a new "
                                     "--out, or move the file away")
                continue
            done.add(_check_row(fields, number, columns, figures, known, done, shown))
    return done, None


def _fields(raw: bytes, number: int, shown: str) -> list[str]:
    """The fields of the whole line ``raw`` (its ``\\n`` or ``\\r\\n`` left out): UTF-8,
    printable, one CSV row."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise SweepError(f"{shown}: line {number} is not UTF-8 text; not a results file") from None
    text = text.removesuffix("\n").removesuffix("\r")
    if not text.isprintable():
        bad = next(c for c in text if not c.isprintable())
        raise SweepError(f"{shown}: line {number} holds a character that is not printable "
                         f"({escape(repr(bad))}), which a sweep never writes; the file is damaged")
    try:
        return next(csv.reader([text]), [])
    except csv.Error:
        raise SweepError(f"{shown}: line {number} is not a CSV row") from None


def _check_row(fields: list[str], number: int, columns: tuple[str, ...], figures: list[int],
               known: set[str], done: set[str], shown: str) -> str:
    """The run id of the finished row ``fields``, checked: its number of fields, a run of this
    sweep not seen before, and each figure (column indexes ``figures``) empty or finite."""
    if len(fields) != len(columns):
        raise SweepError(f"{shown}: line {number} has {len(fields)} fields, not "
                         f"{len(columns)}; the file is damaged")
    rid = fields[0]
    if rid not in known:
        raise SweepError(f"{shown}: line {number} holds run {escape(repr(rid))}, which is "
                         "not a run of this sweep (the base scenario or a fixed setting "
                         "changed?); name a new --out")
    if rid in done:
        raise SweepError(f"{shown}: line {number} repeats run {escape(repr(rid))}")
    for i in figures:
        if not _finite(fields[i]):
            text = fields[i] if len(fields[i]) <= 40 else fields[i][:37] + "..."
            raise SweepError(f"{shown}: line {number}: column '{escape(columns[i])}' holds "
                             f"{escape(repr(text))}, not a finite number (nor empty); the file "
                             "is damaged")
    return rid


def _finite(text: str) -> bool:
    """Whether ``text`` is empty or a finite number (as :func:`format_value` writes them)."""
    if text == "" or _INT.fullmatch(text):
        return True
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def _check_half(raw: bytes, number: int, header: bytes, todo: set[str], width: int,
                shown: str) -> None:
    """Refuse the last line ``raw`` (no newline) unless it is the start of what a crash
    leaves: of the header (line 1), or of a row of a run in ``todo``, ``width`` fields at
    most, printable UTF-8 (a character cut at its end allowed)."""
    if number == 1:
        if header.startswith(raw):
            return
        raise SweepError(f"{shown}: line 1 is not a whole header, nor the start of this sweep's; "
                         "not a results file of this sweep")
    try:
        text = codecs.getincrementaldecoder("utf-8")().decode(raw, final=False)
    except UnicodeDecodeError:
        text = None
    if text is not None and text.isprintable():
        fields = next(csv.reader([text]), [""])
        rid = fields[0]
        if len(fields) <= width and (rid in todo if len(fields) > 1
                                     else any(r.startswith(rid) for r in todo)):
            return
    raise SweepError(f"{shown}: line {number} is an unfinished last line that is not the start "
                     "of a row of this sweep (all that a crash leaves); the file is damaged, or "
                     "not this sweep's results")


def open_results(path: Path, columns: tuple[str, ...], known: set[str], *,
                 numbers: tuple[str, ...] = ()) -> tuple[Results, int]:
    """Open ``path`` for appending, creating it with its header if missing; returns it and
    the number of bytes of a half-written last row that was cut off (0: none). ``known``:
    the run ids of this sweep; ``numbers``: the columns that hold an empty field or a
    finite number (the seed, the figures)."""
    shown = escape(str(path))
    try:
        if not path.exists():
            _create(path, columns)
            return Results(path, columns, set()), 0
        if not path.is_file():
            raise SweepError(f"{shown}: is not a file")
        if path.stat().st_size == 0:  # created but its header never written
            _create(path, columns)
            return Results(path, columns, set()), 0
        done, cut = _scan(path, columns, known, numbers)
        dropped = 0
        if cut is not None:
            dropped = path.stat().st_size - cut
            if cut == 0:  # not even the header was whole
                _create(path, columns)
                return Results(path, columns, set()), dropped
            os.truncate(path, cut)
        return Results(path, columns, done), dropped
    except OSError as exc:
        raise SweepError(f"{shown}: cannot be read or written: {escape(exc.strerror or str(exc))}") from None


_TEXT = ("run_id", "job", "error")


def _typed(header: tuple[str, ...], fields: list[str]) -> dict[str, Any]:
    return {k: (v or None) if k in _TEXT else parse_value(v) for k, v in zip(header, fields, strict=True)}


def read_rows(path: Path) -> tuple[tuple[str, ...], list[dict[str, Any]]]:
    """The columns and the rows (typed values; ``run_id``, ``job`` and ``error`` stay text)
    of a results file, for the report."""
    shown = escape(str(path))
    try:
        with open(path, encoding="utf-8", newline="") as f:
            reader = csv.reader(f)
            header = tuple(next(reader, ()))
            rows = [_typed(header, r) for r in reader if len(r) == len(header)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise SweepError(f"{shown}: cannot be read: {escape(str(exc))}") from None
    return header, rows
