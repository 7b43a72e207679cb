"""Settings built in code are checked as the loader checks them.

``VisionSettings(segmentation="bogus")``, ``RobotSettings(max_joint_speed=-1)`` or
``dataclasses.replace(scenario.parts, count=0)`` raise the loader's ``ScenarioError``,
naming the key as ``section.key`` (prefixed by the class's name instead of a file): a
settings object that exists is valid however it was made.
"""

from __future__ import annotations

import dataclasses
import math
import typing

import numpy as np
import pytest

from cell.config import build, check, setting
from cell.errors import ScenarioError
from cell.jobs.settings import SortSettings
from cell.robot.settings import RobotSettings
from cell.scenario import Scenario, scenario_from_dict
from cell.vision.settings import VisionSettings

# (section, class): every section of a scenario, and the scenario itself ("")
SECTIONS = [("", Scenario)] + [
    (f.name, typing.get_type_hints(Scenario)[f.name])
    for f in dataclasses.fields(Scenario)
    if dataclasses.is_dataclass(typing.get_type_hints(Scenario)[f.name])
]


def _fields():
    for section, cls in SECTIONS:
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            if not dataclasses.is_dataclass(hints[f.name]):
                yield section, cls, f, hints[f.name]


FIELDS = list(_fields())


def _elem(tp):
    return typing.get_args(tp)[0] if typing.get_origin(tp) is tuple else tp


def _as_field(tp, item, f):
    """``item`` as the whole value of a field of type ``tp`` (a sequence of the right length)."""
    if typing.get_origin(tp) is not tuple:
        return item
    return (item,) * (f.metadata.get("length") or 1)


def _cases():
    """(section, class, field, bad value, what the message says) for every field."""
    for section, cls, f, tp in FIELDS:
        meta, elem = f.metadata, _elem(tp)
        yield section, cls, f, _as_field(tp, object(), f), "must be"
        if elem in (int, float) and meta.get("hi") is not None:
            too_big = meta["hi"] + 1
            yield section, cls, f, _as_field(tp, elem(too_big), f), "is out of range"
        if elem in (int, float) and meta.get("lo") is not None:
            too_small = meta["lo"] - 1
            yield section, cls, f, _as_field(tp, elem(too_small), f), "is out of range"
        if elem is float:
            yield section, cls, f, _as_field(tp, math.nan, f), "must be a finite number"
            yield section, cls, f, _as_field(tp, -math.inf, f), "must be a finite number"
        if meta.get("choices") is not None:
            bogus = "bogus" if elem is str else 12345
            yield section, cls, f, _as_field(tp, bogus, f), "has invalid value"
        if elem is str:
            yield section, cls, f, _as_field(tp, "a\x1b[2Jb", f), "printable characters only"
        if elem is int:
            yield section, cls, f, _as_field(tp, True, f), "must be int"
        if meta.get("length") is not None:
            default = f.default
            yield section, cls, f, default + default[:1], f"must have {meta['length']} elements"


CASES = list(_cases())


def _key(section: str, name: str) -> str:
    return f"{section}.{name}" if section else name


@pytest.mark.parametrize(
    ("section", "cls", "field", "value", "says"), CASES,
    ids=[f"{_key(s, f.name)}-{says.split()[-1]}-{i}" for i, (s, _, f, _, says) in enumerate(CASES)],
)
def test_a_bad_value_built_in_code_names_the_key_as_the_loader_does(section, cls, field, value, says):
    key = _key(section, field.name)
    with pytest.raises(ScenarioError) as in_code:
        cls(**{field.name: value})
    message = str(in_code.value)
    assert message.startswith(f"{cls.__name__}: key '{key}' "), message
    assert says in message and message.isprintable(), message
    # the very message of the loader, but for where the value came from
    with pytest.raises(ScenarioError) as loaded:
        scenario_from_dict({section: {field.name: value}} if section else {field.name: value},
                           where="s.toml")
    assert str(loaded.value) == "s.toml" + message.removeprefix(cls.__name__)


@pytest.mark.parametrize(("section", "cls"), SECTIONS, ids=[s or "scenario" for s, _ in SECTIONS])
def test_a_valid_one_built_in_code_equals_the_loaded_default(section, cls):
    loaded = scenario_from_dict({})
    assert cls() == (getattr(loaded, section) if section else loaded)
    # given as the loader is given them (lists; integers for floats) and normalised alike
    plain = {f.name: list(v) if isinstance(v, tuple) else v
             for f in dataclasses.fields(cls)
             for v in [getattr(cls(), f.name)]
             if not dataclasses.is_dataclass(v)}
    plain = {k: int(v) if isinstance(v, float) and v.is_integer() and abs(v) < 1e15 else v
             for k, v in plain.items()}
    built = cls(**plain)
    assert built == cls() and hash(built) == hash(cls())
    for f in dataclasses.fields(cls):
        assert type(getattr(built, f.name)) is type(getattr(cls(), f.name)), f.name


def test_the_examples_of_the_readme_fail_on_construction():
    with pytest.raises(ScenarioError, match=r"^VisionSettings: key 'vision\.segmentation' has invalid "
                                            r"value 'bogus'; valid: belt, fixed, otsu"):
        VisionSettings(segmentation="bogus")
    with pytest.raises(ScenarioError, match=r"^RobotSettings: key 'robot\.max_joint_speed' = -1\.0 "
                                            r"is out of range \[1\.0, 180\.0\]"):
        RobotSettings(max_joint_speed=-1)
    scenario = scenario_from_dict({})
    with pytest.raises(ScenarioError, match=r"^PartsSettings: key 'parts\.count' = 0 is out of range"):
        dataclasses.replace(scenario.parts, count=0)
    with pytest.raises(ScenarioError, match=r"^Scenario: key 'seed' = -1 is out of range"):
        dataclasses.replace(scenario, seed=-1)
    with pytest.raises(ScenarioError, match=r"^Scenario: section 'vision' must be VisionSettings, "
                                            r"got dict"):
        Scenario(vision={"segmentation": "otsu"})


def test_cross_field_checks_apply_in_code_too():
    with pytest.raises(ScenarioError, match=r"^VisionSettings: key 'vision\.smooth' must be odd or 0"):
        VisionSettings(smooth=4)
    with pytest.raises(ScenarioError, match=r"^VisionSettings: key 'vision\.belt_y' must be \[low, high\]"):
        VisionSettings(belt_y=[0.5, 0.4])
    with pytest.raises(ScenarioError, match=r"^SortSettings: key 'sort\.pick_window' must be"):
        SortSettings(pick_window=(0.1, -0.1))
    with pytest.raises(ScenarioError, match=r"^PartsSettings: key 'parts\.kinds' must not be empty"):
        dataclasses.replace(scenario_from_dict({}).parts, kinds=())


def test_values_from_code_are_normalised_as_the_loader_normalises_them():
    v = VisionSettings(belt_rgb=np.array([0.22, 0.30, 0.42]), belt_y=[0.37, 0.53],
                       threshold=np.int64(150), noise_k=4, plane_z=np.float32(0.5))
    assert v.belt_rgb == (0.22, 0.30, 0.42) and type(v.belt_rgb) is tuple
    assert v.belt_y == (0.37, 0.53) and type(v.belt_y) is tuple
    assert type(v.threshold) is int and type(v.noise_k) is float and type(v.plane_z) is float
    assert dataclasses.replace(v, plane_z=0.08, threshold=150) == VisionSettings(belt_y=(0.37, 0.53))
    assert v == scenario_from_dict({"vision": {"belt_y": [0.37, 0.53], "noise_k": 4,
                                               "plane_z": 0.5}}).vision
    hash(v)  # (a list kept as given would make it unhashable)


def test_a_loader_error_names_the_file_not_the_class():
    with pytest.raises(ScenarioError, match=r"^x\.toml: key 'vision\.segmentation' has invalid"):
        scenario_from_dict({"vision": {"segmentation": "bogus"}}, where="x.toml")
    with pytest.raises(ScenarioError, match=r"^--set robot\.max_joint_speed=-1: key 'robot\."):
        scenario_from_dict({}, overrides=["robot.max_joint_speed=-1"])
    # ... and leaves nothing behind: code built after it is named by its class again
    with pytest.raises(ScenarioError, match=r"^VisionSettings: key 'vision\.threshold'"):
        VisionSettings(threshold=300)


@dataclasses.dataclass(frozen=True)
class _Unchecked:
    """A settings class whose ``__post_init__`` does not call ``check`` (as a sweep job's)."""

    level: float = setting(1.0, lo=0.0, hi=2.0)

    def _validate(self, where: str) -> None:
        if self.level == 1.5:
            raise ScenarioError(f"{where}: key 'job.level' must not be 1.5")


@dataclasses.dataclass(frozen=True)
class _Checked:
    level: float = setting(1.0, lo=0.0, hi=2.0)
    names: tuple[str, ...] = setting(("a",), choices=("a", "b"))

    def __post_init__(self) -> None:
        check(self, "job")


def test_build_checks_a_class_that_does_not_check_itself():
    assert build(_Unchecked, {"level": 2}, where="w", prefix="job.").level == 2.0
    with pytest.raises(ScenarioError, match=r"^w: key 'job\.level' = 3\.0 is out of range"):
        build(_Unchecked, {"level": 3}, where="w", prefix="job.")
    with pytest.raises(ScenarioError, match=r"^w: key 'job\.level' must not be 1\.5"):
        build(_Unchecked, {"level": 1.5}, where="w", prefix="job.")


def test_a_class_that_checks_itself_is_checked_once_by_build_with_its_prefix():
    assert build(_Checked, {"names": ["b"]}, where="w", prefix="job.").names == ("b",)
    with pytest.raises(ScenarioError, match=r"^w: key 'job\.names' has invalid value 'c'"):
        build(_Checked, {"names": ["c"]}, where="w", prefix="job.")
    with pytest.raises(ScenarioError, match=r"^_Checked: key 'job\.level' = -1\.0 is out of range"):
        _Checked(level=-1)
