"""The scenario's [robot] section."""

from __future__ import annotations

import pytest

from cell.errors import ScenarioError
from cell.scenario import scenario_from_dict


def test_robot_limits_come_from_the_scenario_with_ur5e_defaults():
    s = scenario_from_dict({}, overrides=["robot.max_joint_accel=500"])
    assert s.robot.max_joint_speed == 180.0
    assert s.robot.max_joint_accel == 500.0


def test_a_speed_above_the_ur5e_rating_is_refused_naming_the_key():
    with pytest.raises(ScenarioError, match=r"robot.max_joint_speed.*out of range"):
        scenario_from_dict({"robot": {"max_joint_speed": 250.0}}, where="x.toml")
