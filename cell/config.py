"""Typed settings: frozen dataclasses validated from plain dicts (TOML) and overrides.

A settings class is a frozen dataclass whose fields are declared with :func:`setting`,
which records the default, an optional numeric range, an optional set of choices and a
one-line doc. :func:`build` turns a nested dict (as read from TOML) into such a class,
checking every key, type, range and choice; :func:`apply_override` parses one
``key=value`` string (dotted keys for sections). Every failure is a ``ScenarioError``
whose message names the key and where it came from (a file or ``--set``).

Supported field types: ``bool``, ``int``, ``float``, ``str``, ``tuple[float, ...]``,
``tuple[int, ...]``, ``tuple[str, ...]`` and nested settings dataclasses.
"""

from __future__ import annotations

import dataclasses
import tomllib
import typing
from typing import Any

from cell.errors import ScenarioError

__all__ = ["apply_override", "build", "describe", "setting", "to_dict"]


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


def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _type_name(tp: Any) -> str:
    if typing.get_origin(tp) is tuple:
        return f"list of {typing.get_args(tp)[0].__name__}"
    return getattr(tp, "__name__", str(tp))


def _coerce_scalar(value: Any, tp: type, key: str, where: str) -> Any:
    ok = False
    if tp is bool:
        ok = isinstance(value, bool)
    elif tp is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif tp is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        value = float(value) if ok else value
    elif tp is str:
        ok = isinstance(value, str)
    if not ok:
        raise ScenarioError(
            f"{where}: key '{key}' must be {_type_name(tp)}, got {type(value).__name__} {value!r}"
        )
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
            raise ScenarioError(f"{where}: key '{key}' has invalid value {item!r}; valid: {valid}")
        lo, hi = meta.get("lo"), meta.get("hi")
        if (lo is not None and item < lo) or (hi is not None and item > hi):
            raise ScenarioError(
                f"{where}: key '{key}' = {item!r} is out of range [{lo}, {hi}]"
            )


def _coerce(value: Any, tp: Any, meta: dict[str, Any], key: str, where: str) -> Any:
    if typing.get_origin(tp) is tuple:
        elem = typing.get_args(tp)[0]
        if not isinstance(value, (list, tuple)):
            raise ScenarioError(
                f"{where}: key '{key}' must be {_type_name(tp)}, got {type(value).__name__} {value!r}"
            )
        out = tuple(_coerce_scalar(v, elem, key, where) for v in value)
    else:
        out = _coerce_scalar(value, tp, key, where)
    _check_value(out, meta, key, where)
    return out


def build(cls: type, data: dict[str, Any], *, where: str, prefix: str = "") -> Any:
    """Validate ``data`` (a nested dict) into the settings dataclass ``cls``.

    ``where`` names the source (a file path) in error messages; ``prefix`` is the dotted
    path of ``cls`` inside the scenario. Missing keys take their defaults.
    """
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: section '{prefix.rstrip('.')}' must be a table")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = _hints(cls)
    unknown = sorted(set(data) - set(fields))
    if unknown:
        valid = ", ".join(prefix + name for name in fields)
        raise ScenarioError(f"{where}: unknown key '{prefix}{unknown[0]}'; valid keys: {valid}")
    kwargs = {}
    for name, value in data.items():
        tp = hints[name]
        key = prefix + name
        if dataclasses.is_dataclass(tp):
            kwargs[name] = build(tp, value, where=where, prefix=key + ".")
        else:
            kwargs[name] = _coerce(value, tp, dict(fields[name].metadata), key, where)
    obj = cls(**kwargs)
    check = getattr(obj, "_validate", None)
    if check is not None:
        check(where)
    return obj


def _parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text  # a bare word: a string such as `lighting=back`


def apply_override(data: dict[str, Any], assignment: str, cls: type) -> dict[str, Any]:
    """Return a copy of ``data`` with one ``key=value`` override applied.

    The value is read as a TOML value (``3``, ``0.2``, ``true``, ``[1, 2]``, ``"x"``); a
    bare word that is not TOML is taken as a string. The key is checked against ``cls``.
    """
    where = f"--set {assignment}"
    if "=" not in assignment:
        raise ScenarioError(f"{where}: expected key=value, e.g. --set parts.count=5")
    key, _, text = assignment.partition("=")
    key = key.strip()
    parts = key.split(".")
    out = _deep_copy(data)
    node, node_cls, prefix = out, cls, ""
    for i, name in enumerate(parts):
        fields = {f.name for f in dataclasses.fields(node_cls)}
        if name not in fields:
            valid = ", ".join(prefix + f for f in sorted(fields))
            raise ScenarioError(f"{where}: unknown key '{prefix}{name}'; valid keys: {valid}")
        tp = _hints(node_cls)[name]
        if i == len(parts) - 1:
            if dataclasses.is_dataclass(tp):
                raise ScenarioError(f"{where}: '{key}' is a section; set one of its keys")
            node[name] = _parse_value(text.strip())
        else:
            if not dataclasses.is_dataclass(tp):
                raise ScenarioError(f"{where}: '{prefix}{name}' is not a section")
            node = node.setdefault(name, {})
            node_cls, prefix = tp, prefix + name + "."
    return out


def _deep_copy(data: dict[str, Any]) -> dict[str, Any]:
    return {k: _deep_copy(v) if isinstance(v, dict) else v for k, v in data.items()}


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
