"""The robot: pinocchio kinematics, mink IK, time-scaled motion, suction, pick-and-place.

Names load lazily (``from cell.robot import PickPlace``), so that reading the settings
(``cell.robot.settings``, used by the scenario) does not import pinocchio and mink.
"""

from __future__ import annotations

from cell.lazy import lazy_names

__all__ = [
    "GRASP_POINTS",
    "ArmDriver",
    "ArmIK",
    "ArmKinematics",
    "PartTarget",
    "PickPlace",
    "PickResult",
    "RobotSettings",
    "Segment",
    "Setpoint",
    "SuctionCup",
    "choose_tool_yaw",
    "down_rotation",
    "min_time",
    "plan_segment",
    "tool_yaw",
]

_WHERE = {
    "GRASP_POINTS": "pick", "PartTarget": "pick", "PickPlace": "pick", "PickResult": "pick",
    "choose_tool_yaw": "pick", "ArmDriver": "motion", "ArmIK": "ik", "down_rotation": "ik",
    "tool_yaw": "ik", "ArmKinematics": "kinematics", "RobotSettings": "settings",
    "Segment": "trajectory", "Setpoint": "trajectory", "min_time": "trajectory", "plan_segment": "trajectory",
    "SuctionCup": "suction",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
