"""Property: any scenario input is either a valid ``Scenario`` or one clear ``ScenarioError``.

Random nested dicts (valid dotted keys, section names and junk keys; values that are huge
integers, NaN, infinities, strings with control characters, lists and tables), random
``--set key=value`` overrides and random file bytes go through the loaders. The only
allowed outcomes are a ``Scenario`` whose numbers are all finite and whose strings are all
printable, or a ``ScenarioError`` whose message is printable and names a key (or the
``--set`` / file it came from). Any other exception fails the test.
"""

from __future__ import annotations

import json
import math
import re
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cell.config import describe, to_dict
from cell.errors import ScenarioError
from cell.scenario import Scenario, load_scenario, scenario_from_dict

VALID_KEYS = [row[0] for row in describe(Scenario)]
SECTIONS = sorted({key.rsplit(".", 1)[0] for key in VALID_KEYS if "." in key})
NAMES_A_KEY = re.compile(r"(key|section) '[^']*'")
SETTINGS = settings(max_examples=300, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

nasty_text = st.one_of(
    st.text(max_size=10),
    st.sampled_from(["\x1b]0;pwned\x07", "\x1b[2J", "\x00", "a\nb", "\u009b31m", "\ufeff",
                     "\t", "\x7f", "front", "back", "washer", "index", "otsu", ""]),
)
huge_ints = st.sampled_from([10**400, -(10**400), 10**4200, 2**63, 2**63 - 1, 2**64, -1])
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    huge_ints,
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-2.0, max_value=2.0),
    st.sampled_from([math.nan, math.inf, -math.inf, 1e308, 5e-324]),
    nasty_text,
)
values = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=6) | st.dictionaries(nasty_text, inner, max_size=4),
    max_leaves=12,
)
keys = st.one_of(
    st.sampled_from(VALID_KEYS + SECTIONS),
    nasty_text,
    st.builds(lambda s, k: f"{s}.{k}", st.sampled_from(SECTIONS), nasty_text),
)


def _nest(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A nested dict with each value placed at its dotted key (later pairs win)."""
    root: dict[str, Any] = {}
    for key, value in pairs:
        *sections, leaf = key.split(".")
        node = root
        for name in sections:
            if not isinstance(node.get(name), dict):
                node[name] = {}
            node = node[name]
        node[leaf] = value
    return root


def _toml_literal(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_literal(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml_literal(v)}" for k, v in value.items()) + "}"
    return "nothing"  # None: not TOML, read as a bare word


assignments = st.one_of(
    st.builds(lambda k, v: f"{k}={_toml_literal(v)}", keys, values),
    st.builds(lambda k, v: f"{k}={v}", keys, nasty_text),
    nasty_text,
)


def _walk(node: Any):
    if isinstance(node, dict):
        for value in node.values():
            yield from _walk(value)
    elif isinstance(node, list):
        for value in node:
            yield from _walk(value)
    else:
        yield node


def _check_outcome(load) -> None:
    try:
        scenario = load()
    except ScenarioError as exc:
        message = str(exc)
        assert message.isprintable(), message
        assert NAMES_A_KEY.search(message) or "expected key=value" in message, message
        return
    assert isinstance(scenario, Scenario)
    for leaf in _walk(to_dict(scenario)):
        if isinstance(leaf, float):
            assert math.isfinite(leaf), leaf
        if isinstance(leaf, str):
            assert leaf.isprintable(), leaf
    assert scenario_from_dict(to_dict(scenario)) == scenario


@SETTINGS
@given(st.lists(st.tuples(keys, values), max_size=6))
def test_random_scenario_dict_is_valid_or_a_scenario_error_naming_a_key(pairs):
    data = _nest(pairs)
    _check_outcome(lambda: scenario_from_dict(data))


@SETTINGS
@given(st.lists(assignments, min_size=1, max_size=4))
def test_random_overrides_are_valid_or_a_scenario_error_naming_a_key(overrides):
    def load():
        try:
            return scenario_from_dict({}, overrides=overrides)
        except ScenarioError as exc:
            assert str(exc).startswith("--set "), str(exc)
            raise

    _check_outcome(load)


@SETTINGS
@given(st.lists(st.tuples(keys, values), max_size=6), st.lists(assignments, max_size=2))
def test_random_dict_with_overrides_is_valid_or_a_scenario_error(pairs, overrides):
    data = _nest(pairs)
    _check_outcome(lambda: scenario_from_dict(data, overrides=overrides))


@SETTINGS
@given(st.one_of(
    st.binary(max_size=200),
    st.builds(lambda pairs: "\n".join(f"{json.dumps(k)} = {_toml_literal(v)}" for k, v in pairs)
              .encode(), st.lists(st.tuples(keys, values), max_size=6)),
    st.builds(lambda k, v: f"[{k}]\n".encode() + v, st.sampled_from(SECTIONS),
              st.binary(max_size=60)),
))
def test_random_file_bytes_load_or_give_a_scenario_error_naming_the_file(data):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.toml"
        path.write_bytes(data)
        try:
            scenario = load_scenario(path)
        except ScenarioError as exc:
            message = str(exc)
            assert message.isprintable() and message.startswith(f"{path}: "), message
            return
        assert isinstance(scenario, Scenario)
