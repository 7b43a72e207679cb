"""A sweep's grid: axes of values (lists and ranges) and the points of their product.

An axis is one dotted key and its values (``"vision.threshold" = [100, 150]``), or several
keys set together, written as a list of tables (``camera = [{width = 160, height = 120},
{width = 320, height = 240}]``: two values, each setting ``camera.width`` and
``camera.height``). A value may be a range table: ``{from = 0, to = 255, step = 15}``
(``to`` included when the steps land on it; ``step`` defaults to 1) or ``{from = 0.0, to = 1.0, count = 5}``
(evenly spaced, both ends included); a single value is an axis of one value; a list is
the axis' values (so a list-valued key such as ``sensor.distortion`` takes a list of
lists). Nested tables are flattened into dotted keys (``[grid.vision]`` with
``threshold = [...]`` is ``vision.threshold``).

:func:`product` yields the grid points of some axes (the first axis outermost) as plain
dicts of dotted keys. Every number must be finite; a range may not hold more than
``MAX_AXIS`` values.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from cell.sweep.errors import SweepError
from cell.text import escape, show

__all__ = ["MAX_AXIS", "Axis", "expand_range", "flatten", "parse_axes", "product", "size"]

MAX_DEPTH = 16  # dotted parts of a key at most (settings have three)
MAX_AXIS = 100_000  # values of one axis
_RANGE_KEYS = {"from", "to", "step", "count"}


@dataclass(frozen=True)
class Axis:
    """One axis of a grid: ``keys`` (dotted, set together) and ``values``: one tuple per
    value, holding a value for each key."""

    keys: tuple[str, ...]
    values: tuple[tuple[Any, ...], ...]


def _is_range(value: object) -> bool:
    return isinstance(value, dict) and "from" in value and set(value) <= _RANGE_KEYS


def _number(value: object, what: str, where: str) -> int | float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SweepError(f"{where}: {what} must be a number, got {show(value)}")
    if isinstance(value, float) and not math.isfinite(value):
        raise SweepError(f"{where}: {what} must be a finite number, got {show(value)}")
    if isinstance(value, int) and abs(value) > 2**63:
        raise SweepError(f"{where}: {what} is out of range (more than 2**63 in size)")
    return value


def expand_range(spec: dict, key: str, where: str) -> list[int | float]:
    """The values of a range table ``{from, to[, step]}`` or ``{from, to, count}``."""
    what = f"range of key '{escape(key)}'"
    if "to" not in spec or ("step" in spec and "count" in spec):
        raise SweepError(f"{where}: {what} needs 'from', 'to' and at most one of 'step' (default "
                         f"1) or 'count', got keys {', '.join(sorted(escape(str(k)) for k in spec))}")
    lo = _number(spec["from"], f"{what}: 'from'", where)
    hi = _number(spec["to"], f"{what}: 'to'", where)
    if hi < lo:
        raise SweepError(f"{where}: {what}: 'to' ({show(hi)}) is below 'from' ({show(lo)})")
    if "count" in spec:
        count = spec["count"]
        if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_AXIS:
            raise SweepError(f"{where}: {what}: 'count' must be an integer from 1 to {MAX_AXIS}, "
                             f"got {show(count)}")
        if count == 1:
            return [lo]
        out = [_tidy(v) for v in _spaced(lo, hi, count)]
        out[-1] = hi
        ints = all(isinstance(v, int) for v in (lo, hi)) and all(float(v).is_integer() for v in out)
        return [int(v) for v in out] if ints else [float(v) for v in out]
    step = _number(spec.get("step", 1), f"{what}: 'step'", where)
    if step <= 0:
        raise SweepError(f"{where}: {what}: 'step' must be above 0, got {show(step)}")
    n = _steps(lo, hi, step)
    if n is None:
        raise SweepError(f"{where}: {what} (from {show(lo)} to {show(hi)} in steps of {show(step)}) "
                         f"holds too many values to count; at most {MAX_AXIS}")
    if n > MAX_AXIS:
        raise SweepError(f"{where}: {what} holds {n} values; at most {MAX_AXIS}")
    if all(isinstance(v, int) for v in (lo, hi, step)):
        return [lo + i * step for i in range(n)]
    return [_tidy(float(lo) + i * float(step)) for i in range(n)]


def _steps(lo: int | float, hi: int | float, step: int | float) -> int | None:
    """The number of values of the range ``lo`` to ``hi`` in steps of ``step`` (``hi``
    included when a step lands on it within rounding); None when it is too large for a
    float (``hi - lo`` or ``(hi - lo) / step`` overflows)."""
    steps = (hi - lo) / step * (1 + 1e-12) + 1e-9
    return math.floor(steps) + 1 if math.isfinite(steps) else None


def _spaced(lo: int | float, hi: int | float, count: int) -> list[float]:
    """``count`` evenly spaced values from ``lo`` to ``hi``; when ``hi - lo`` overflows a
    float, interpolated between the ends instead (every value stays finite)."""
    step = (hi - lo) / (count - 1)
    if math.isfinite(step):
        return [lo + i * step for i in range(count)]
    return [lo * (1 - i / (count - 1)) + hi * (i / (count - 1)) for i in range(count)]


def _tidy(value: float) -> float:
    """``value`` rounded to 12 significant digits: 0.1 * 3 is 0.3, not 0.30000000000000004."""
    return float(f"{value:.12g}")


def flatten(table: dict, where: str, prefix: str = "") -> dict[str, Any]:
    """A nested table as dotted keys; range tables and non-table values are leaves."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        if not isinstance(key, str) or not key or any(not part for part in key.split(".")):
            raise SweepError(f"{where}: invalid key {show(key)}")
        dotted = prefix + key
        if isinstance(value, dict) and not _is_range(value):
            out.update(flatten(value, where, _deeper(dotted, where) + "."))
        else:
            out[dotted] = value
    return out


def _deeper(key: str, where: str) -> str:
    """``key``, a table about to be entered; a ``SweepError`` when it is nested deeper than
    any setting (a key of thousands of dotted parts would exhaust the recursion)."""
    if key.count(".") >= MAX_DEPTH:
        shown = key if len(key) <= 60 else key[:57] + "..."
        raise SweepError(f"{where}: key '{escape(shown)}' is nested more than {MAX_DEPTH} "
                         "tables deep; no setting is")
    return key


def _scalar(value: object, key: str, where: str) -> object:
    """A leaf value, checked: finite numbers (list elements too), no tables."""
    if isinstance(value, dict):
        raise SweepError(f"{where}: key '{escape(key)}': a table is no value here, got {show(value)}")
    if isinstance(value, list):
        return [_scalar(v, key, where) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        raise SweepError(f"{where}: key '{escape(key)}' must be a finite number, got {show(value)}")
    return value


def _values(value: object, key: str, where: str) -> list:
    if _is_range(value):
        return expand_range(value, key, where)
    if isinstance(value, list):
        if not value:
            raise SweepError(f"{where}: key '{escape(key)}' has no values (an empty list)")
        if len(value) > MAX_AXIS:
            raise SweepError(f"{where}: key '{escape(key)}' has {len(value)} values; at most {MAX_AXIS}")
        out = []
        for v in value:
            out += expand_range(v, key, where) if _is_range(v) else [_scalar(v, key, where)]
        return out
    return [_scalar(value, key, where)]


def _zipped(key: str, tables: list[dict], where: str) -> Axis:
    """An axis from a list of tables: each table sets several keys at once."""
    rows = [flatten(t, where, key + ".") for t in tables]
    keys = tuple(rows[0])
    for row in rows[1:]:
        if tuple(row) != keys:
            raise SweepError(f"{where}: key '{escape(key)}': every table of the list must set the "
                             f"same keys ({', '.join(keys)})")
    for row in rows:
        for k, v in row.items():
            if _is_range(v) or isinstance(v, dict):
                raise SweepError(f"{where}: key '{escape(k)}': no ranges inside a list of tables")
    return Axis(keys, tuple(tuple(_scalar(row[k], k, where) for k in keys) for row in rows))


def parse_axes(table: dict, where: str, *, reserved: tuple[str, ...] = ()) -> list[Axis]:
    """The axes of a grid table, in the file's order; keys in ``reserved`` are skipped."""
    axes = []
    for key, value in table.items():
        if key in reserved:
            continue
        if isinstance(value, list) and value and all(isinstance(v, dict) and not _is_range(v)
                                                     for v in value):
            axes.append(_zipped(key, value, where))
            continue
        if isinstance(value, list) and any(isinstance(v, dict) and not _is_range(v) for v in value):
            raise SweepError(f"{where}: key '{escape(key)}' mixes tables and values")
        if isinstance(value, dict) and "from" in value and not _is_range(value):
            extra = sorted(escape(str(k)) for k in set(value) - _RANGE_KEYS)
            raise SweepError(f"{where}: range of key '{escape(key)}': unknown key "
                             f"{', '.join(repr(k) for k in extra)}; a range takes 'from', 'to' "
                             "and 'step' or 'count'")
        if isinstance(value, dict) and not _is_range(value):
            axes += parse_axes({f"{_deeper(key, where)}.{k}": v for k, v in value.items()}, where)
            continue
        axes.append(Axis((key,), tuple((v,) for v in _values(value, key, where))))
    seen: set[str] = set()
    for axis in axes:
        for key in axis.keys:
            if key in seen:
                raise SweepError(f"{where}: key '{escape(key)}' is given twice")
            seen.add(key)
        values = [repr(_same(v)) for v in axis.values]
        if len(set(values)) < len(values):  # (one run each: the grid would say more values)
            twice = next(v for v in axis.values if values.count(repr(_same(v))) > 1)
            shown = show(twice[0] if len(twice) == 1 else dict(zip(axis.keys, twice, strict=True)))
            raise SweepError(f"{where}: key '{escape(', '.join(axis.keys))}' lists the value "
                             f"{shown} twice")
    return axes


def _same(value: object) -> object:
    """``value`` with its numbers as floats: 100 and 100.0 are one setting."""
    if isinstance(value, tuple | list):
        return tuple(_same(v) for v in value)
    if isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


def size(axes: list[Axis] | tuple[Axis, ...]) -> int:
    """Points in the product of ``axes``."""
    return math.prod(len(a.values) for a in axes)


def product(axes: list[Axis] | tuple[Axis, ...]) -> Iterator[dict[str, Any]]:
    """The grid points of ``axes`` (the first axis outermost), each a dict of dotted keys."""
    for combo in itertools.product(*(a.values for a in axes)):
        point: dict[str, Any] = {}
        for axis, values in zip(axes, combo, strict=True):
            point.update(zip(axis.keys, values, strict=True))
        yield point
