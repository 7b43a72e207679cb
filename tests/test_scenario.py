"""Scenario files: defaults, overrides, and errors that name the key and the file."""

from __future__ import annotations

from pathlib import Path

import pytest

from cell.errors import ScenarioError
from cell.scenario import Scenario, load_scenario, scenario_from_dict

SCENARIOS = sorted(Path(__file__).parent.parent.joinpath("scenarios").glob("*.toml"))


def test_empty_scenario_takes_every_default():
    assert scenario_from_dict({}) == Scenario()


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.name)
def test_every_scenario_file_loads(path):
    assert isinstance(load_scenario(path), Scenario)


def test_overrides_apply_with_dotted_keys_and_toml_values():
    s = scenario_from_dict({}, overrides=["parts.count=5", "lighting=back", "conveyor.speed=0.2",
                                          "sensor.distortion=[0.1, 0, 0, 0, 0]", "parts.kinds=['bolt']"])
    assert (s.parts.count, s.lighting, s.conveyor.speed) == (5, "back", 0.2)
    assert s.sensor.distortion == (0.1, 0, 0, 0, 0) and s.parts.kinds == ("bolt",)


def test_seed_argument_overrides_the_file(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text("seed = 4\n")
    assert load_scenario(f).seed == 4
    assert load_scenario(f, seed=11).seed == 11


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("[parts]\ncuont = 3\n", "unknown key 'parts.cuont'"),
        ("[parts]\ncount = 'many'\n", "key 'parts.count' must be int"),
        ("[parts]\ncount = 0\n", "key 'parts.count' = 0 is out of range"),
        ("[conveyor]\nspeed = 9.0\n", "key 'conveyor.speed'"),
        ("[conveyor]\nmode = 'fast'\n", "valid: index, continuous"),
        ("lighting = 'disco'\n", "valid: front, back, raking"),
        ("[parts]\nkinds = ['washer', 'gear']\n", "'gear'; valid: washer"),
        ("[sensor]\ndistortion = [0.1]\n", "key 'sensor.distortion' must have 5 elements"),
        ("[sensor]\nbits = true\n", "key 'sensor.bits' must be int"),
        ("parts = 3\n", "section 'parts' must be a table"),
        ("seed = \n", "not valid TOML"),
    ],
)
def test_bad_input_names_the_key_and_the_file(tmp_path, text, needle):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(f)
    assert needle in str(info.value)
    assert str(f) in str(info.value)


def test_bad_override_names_the_override():
    with pytest.raises(ScenarioError, match=r"--set conveyor\.speed=3: key 'conveyor\.speed'"):
        scenario_from_dict({}, overrides=["conveyor.speed=3"])
    with pytest.raises(ScenarioError, match="unknown key 'camera.zoom'"):
        scenario_from_dict({}, overrides=["camera.zoom=2"])
    with pytest.raises(ScenarioError, match="expected key=value"):
        scenario_from_dict({}, overrides=["parts.count"])


def test_missing_file_is_a_scenario_error(tmp_path):
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario(tmp_path / "nope.toml")
