"""Typed settings: frozen dataclasses validated from plain dicts (TOML) and overrides.

A settings class is a frozen dataclass whose fields are declared with :func:`setting`,
which records the default, an optional numeric range, an optional set of choices and a
one-line doc. Its ``__post_init__`` calls :func:`check`, which applies those rules (and the
class's own cross-field ``_validate(where)``) however the object is made: by the loader, in
code (``VisionSettings(threshold=300)``) or by ``dataclasses.replace``. So a settings object
that exists is valid. :func:`build` turns a nested dict (as read from TOML) into such a
class, checking every key and section and leaving the values to :func:`check`;
:func:`apply_override` parses one ``key=value`` string (dotted keys for sections). Every
failure is a ``ScenarioError`` whose message names the key (``section.key``) and where it
came from: a file or ``--set`` when loaded, the class's name when built in code.

Numbers must be finite (NaN and infinity are rejected, as is an integer too large for a
float) and strings printable. Values are normalised as the loader does: a list becomes a
tuple, an integer given for a float becomes a float (built in code, a NumPy number or a 1-D
array is accepted the same way). Anything a user wrote that a message echoes (a key, a value,
a file name) is shown through :func:`cell.text.escape`, so no message can carry terminal escapes.

Supported field types: ``bool``, ``int``, ``float``, ``str``, ``tuple[float, ...]``,
``tuple[int, ...]``, ``tuple[str, ...]`` and nested settings dataclasses.
"""

from __future__ import annotations

import contextvars
import dataclasses
import functools
import math
import numbers
import tomllib
import typing
from typing import Any

from cell.errors import ScenarioError
from cell.text import escape, override_source, show
from cell.text import summary as _summary

__all__ = ["apply_override", "build", "check", "describe", "setting", "to_dict"]


def setting(
    default: Any,
    *,
    lo: float | None = None,
    hi: float | None = None,
    choices: tuple[Any, ...] | None = None,
    length: int | None = None,
    doc: str = "",
) -> Any:
    """Declare a settings field.

    Parameters
    ----------
    default : the value when the file does not give one (a tuple for sequences).
    lo, hi : inclusive numeric bounds, applied to a number or to each element of a tuple.
    choices : the valid values of a string (or of each element of a tuple of strings).
    length : the exact length a tuple must have.
    doc : one line with the meaning and the unit.
    """
    if isinstance(default, list):
        default = tuple(default)
    meta = {"lo": lo, "hi": hi, "choices": choices, "length": length, "doc": doc}
    if dataclasses.is_dataclass(default):
        return dataclasses.field(default_factory=lambda: default, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def _got(value: Any) -> str:
    summary = _summary(value)
    return summary if summary is not None else f"{type(value).__name__} {show(value)}"


def _key_text(key: Any) -> str:
    return escape(key) if isinstance(key, str) else show(key)


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _type_name(tp: Any) -> str:
    if typing.get_origin(tp) is tuple:
        return f"list of {typing.get_args(tp)[0].__name__}"
    return getattr(tp, "__name__", str(tp))


def _range_text(meta: dict[str, Any]) -> str:
    return f"[{meta.get('lo')}, {meta.get('hi')}]"


def _finite_float(value: int | float, meta: dict[str, Any], key: str, where: str) -> float:
    try:
        number = float(value)
    except OverflowError:  # an int beyond the largest float
        raise ScenarioError(
            f"{where}: key '{key}' = {show(value)} is out of range {_range_text(meta)}"
        ) from None
    if not math.isfinite(number):
        raise ScenarioError(f"{where}: key '{key}' must be a finite number, got {show(value)}")
    return number


def _printable(value: str, key: str, where: str) -> str:
    if not value.isprintable():
        raise ScenarioError(
            f"{where}: key '{key}' must contain printable characters only (no control "
            f"characters, tabs or newlines), got {show(value)}"
        )
    return value


def _coerce_scalar(value: Any, tp: type, meta: dict[str, Any], key: str, where: str) -> Any:
    # (a NumPy integer or float, as code may pass, is taken as the Python number it holds)
    ok = False
    if tp is bool:
        ok = isinstance(value, bool) or (getattr(value, "dtype", None) is not None
                                         and value.dtype.kind == "b" and value.ndim == 0)
        value = bool(value) if ok else value  # (a NumPy bool, as code may pass)
    elif tp is int:
        ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
        value = int(value) if ok else value
    elif tp is float:
        ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
        value = _finite_float(value, meta, key, where) if ok else value
    elif tp is str:
        ok = isinstance(value, str)
        value = _printable(str(value), key, where) if ok else value
    if not ok:
        raise ScenarioError(f"{where}: key '{key}' must be {_type_name(tp)}, got {_got(value)}")
    return value


def _check_value(value: Any, meta: dict[str, Any], key: str, where: str) -> None:
    items = value if isinstance(value, tuple) else (value,)
    if meta.get("length") is not None and len(items) != meta["length"]:
        raise ScenarioError(
            f"{where}: key '{key}' must have {meta['length']} elements, got {len(items)}"
        )
    for item in items:
        if meta.get("choices") is not None and item not in meta["choices"]:
            valid = ", ".join(str(c) for c in meta["choices"])
            raise ScenarioError(
                f"{where}: key '{key}' has invalid value {show(item)}; valid: {valid}"
            )
        lo, hi = meta.get("lo"), meta.get("hi")
        if (lo is not None and item < lo) or (hi is not None and item > hi):
            raise ScenarioError(
                f"{where}: key '{key}' = {show(item)} is out of range {_range_text(meta)}"
            )


def _sequence(value: Any) -> tuple[Any, ...] | None:
    """``value`` as a tuple if it is a list, a tuple or a 1-D array (NumPy's), else None."""
    if isinstance(value, (list, tuple)):
        return tuple(value)
    if hasattr(value, "__array__") and getattr(value, "ndim", None) == 1:
        return tuple(value.tolist())
    return None


def _coerce(value: Any, tp: Any, meta: dict[str, Any], key: str, where: str) -> Any:
    if typing.get_origin(tp) is tuple:
        elem = typing.get_args(tp)[0]
        items = _sequence(value)
        if items is None:
            raise ScenarioError(f"{where}: key '{key}' must be {_type_name(tp)}, got {_got(value)}")
        out = tuple(_coerce_scalar(v, elem, meta, key, where) for v in items)
    else:
        out = _coerce_scalar(value, tp, meta, key, where)
    _check_value(out, meta, key, where)
    return out


@dataclasses.dataclass
class _Building:
    """The object :func:`build` is constructing: where it comes from and its key prefix."""

    cls: type
    where: str
    prefix: str
    checked: bool = False


_BUILDING: contextvars.ContextVar[_Building | None] = contextvars.ContextVar(
    "cell_config_building", default=None
)


def check(obj: Any, section: str = "") -> None:
    """Check and normalise every field of the settings dataclass ``obj``, in place.

    Call it from the class's ``__post_init__`` with the section's name in a scenario
    (``check(self, "vision")``; ``""`` for the top level). Each field must satisfy its
    :func:`setting` (type, finite, printable, range, choices, length); a nested section
    must be an instance of its class. Lists become tuples and integers given for floats
    become floats (set on the frozen dataclass). Then the class's own ``_validate(where)``,
    if any, checks across fields.

    Raises ``ScenarioError`` naming the key as ``section.key``: prefixed by the source
    (the file or ``--set``) when :func:`build` is constructing ``obj``, else by the class's
    name (``VisionSettings: key 'vision.threshold' = 300 is out of range [0, 255]``).
    """
    building = _BUILDING.get()
    if building is not None and building.cls is type(obj):
        building.checked = True
        where, prefix = building.where, building.prefix
    else:
        where, prefix = type(obj).__name__, f"{section}." if section else ""
    _check_fields(obj, where, prefix)


def _check_fields(obj: Any, where: str, prefix: str) -> None:
    hints = _hints(type(obj))
    for f in dataclasses.fields(obj):
        tp, key, value = hints[f.name], prefix + f.name, getattr(obj, f.name)
        if dataclasses.is_dataclass(tp):
            if not isinstance(value, tp):
                raise ScenarioError(
                    f"{where}: section '{key}' must be {tp.__name__}, got {_got(value)}"
                )
            continue
        out = _coerce(value, tp, dict(f.metadata), key, where)
        if out is not value:
            object.__setattr__(obj, f.name, out)  # (the frozen dataclass's own normal form)
    cross_check = getattr(obj, "_validate", None)
    if cross_check is not None:
        cross_check(where)


def build(cls: type, data: dict[str, Any], *, where: str, prefix: str = "") -> Any:
    """Validate ``data`` (a nested dict) into the settings dataclass ``cls``.

    ``where`` names the source (a file path) in error messages, escaped; ``prefix`` is the
    dotted path of ``cls`` inside the scenario. Missing keys take their defaults. Keys and
    sections are checked here; the values by :func:`check`, from the class's
    ``__post_init__`` (or here, after construction, for a class that does not call it).
    """
    where = escape(where)
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: section '{prefix.rstrip('.')}' must be a table")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = _hints(cls)
    unknown = sorted((k for k in data if k not in fields), key=_key_text)
    if unknown:
        valid = ", ".join(prefix + name for name in fields)
        raise ScenarioError(
            f"{where}: unknown key '{prefix}{_key_text(unknown[0])}'; valid keys: {valid}"
        )
    kwargs = {}
    for name, value in data.items():
        tp = hints[name]
        if dataclasses.is_dataclass(tp):
            kwargs[name] = build(tp, value, where=where, prefix=prefix + name + ".")
        else:
            kwargs[name] = value
    building = _Building(cls, where, prefix)
    token = _BUILDING.set(building)
    try:
        obj = cls(**kwargs)
    finally:
        _BUILDING.reset(token)
    if not building.checked:  # a settings class whose __post_init__ does not call check
        _check_fields(obj, where, prefix)
    return obj


def _parse_value(text: str, key: str, where: str) -> Any:
    try:
        parsed = tomllib.loads(f"v = {text}")
    except tomllib.TOMLDecodeError:
        return text  # a bare word: a string such as `lighting=back`
    except RecursionError:
        raise ScenarioError(f"{where}: key '{key}': value nested too deeply") from None
    except ValueError:  # tomllib refuses integers over Python's 4,300-digit conversion limit
        raise ScenarioError(f"{where}: key '{key}': an integer of over 4,300 digits") from None
    # `1\nname = "x"` would smuggle in a second key: such text is a (bad) string, not TOML
    return parsed["v"] if set(parsed) == {"v"} else text


def apply_override(data: dict[str, Any], assignment: str, cls: type) -> dict[str, Any]:
    """Return a copy of ``data`` with one ``key=value`` override applied.

    The value is read as a TOML value (``3``, ``0.2``, ``true``, ``[1, 2]``, ``"x"``); a
    bare word that is not TOML is taken as a string. The key is checked against ``cls``.
    """
    where = override_source(assignment)
    if "=" not in assignment:
        raise ScenarioError(f"{where}: expected key=value, e.g. --set parts.count=5")
    key, _, text = assignment.partition("=")
    key = key.strip()
    parts = key.split(".")
    out = dict(data)  # copied along the key's path only: the rest is not modified
    node, node_cls, prefix = out, cls, ""
    for i, name in enumerate(parts):
        fields = {f.name for f in dataclasses.fields(node_cls)}
        if name not in fields:
            valid = ", ".join(prefix + f for f in sorted(fields))
            raise ScenarioError(
                f"{where}: unknown key '{prefix}{escape(name)}'; valid keys: {valid}"
            )
        tp = _hints(node_cls)[name]
        if i == len(parts) - 1:
            if dataclasses.is_dataclass(tp):
                raise ScenarioError(f"{where}: key '{prefix}{name}' is a section; set one of its keys")
            node[name] = _parse_value(text.strip(), prefix + name, where)
        else:
            if not dataclasses.is_dataclass(tp):
                raise ScenarioError(f"{where}: key '{prefix}{name}' is not a section")
            child = node.get(name, {})
            if not isinstance(child, dict):
                raise ScenarioError(f"{where}: section '{prefix}{name}' must be a table")
            node[name] = node = dict(child)
            node_cls, prefix = tp, prefix + name + "."
    return out


def to_dict(obj: Any) -> dict[str, Any]:
    """A settings dataclass as a plain nested dict (tuples become lists), for reports."""
    out = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            out[f.name] = to_dict(value)
        elif isinstance(value, tuple):
            out[f.name] = list(value)
        else:
            out[f.name] = value
    return out


def describe(cls: type, prefix: str = "") -> list[tuple[str, str, Any, str]]:
    """Rows (key, type, default, doc) for every field of ``cls``, sections flattened."""
    rows = []
    hints = _hints(cls)
    for f in dataclasses.fields(cls):
        tp = hints[f.name]
        if dataclasses.is_dataclass(tp):
            rows += describe(tp, prefix + f.name + ".")
        else:
            default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
            rows.append((prefix + f.name, _type_name(tp), default, f.metadata.get("doc", "")))
    return rows
