"""``RobotSettings``: the arm's motion limits and the pick-and-place parameters.

The scenario's ``[robot]`` section; units in each field's doc.
"""

from __future__ import annotations

from dataclasses import dataclass

from cell.config import setting

__all__ = ["RobotSettings"]


@dataclass(frozen=True)
class RobotSettings:
    """Limits and parameters of the robot.

    ``max_joint_accel`` defaults to 600 deg/s^2 (10.5 rad/s^2). Why: the UR5e publishes
    no joint acceleration limit (URScript's ``movej`` default is a gentle 1.4 rad/s^2).
    The binding joint is the shoulder lift: its 150 N m must hold the stretched arm
    against gravity (about 60 N m) and accelerate about 4 kg m^2 of link inertia plus
    rotor inertia, which leaves room for about 20 rad/s^2. Half of that keeps every
    joint's commanded torque (feed-forward plus servo correction) well inside the UR5e
    efforts, so the servos track the trajectory instead of saturating, while a
    180-degree turn of the base still takes only 1.3 s.
    """

    max_joint_speed: float = setting(
        180.0, lo=1.0, hi=180.0, doc="joint speed limit, every joint (deg/s; UR5e: 180)"
    )
    max_joint_accel: float = setting(
        600.0, lo=10.0, hi=1200.0, doc="joint acceleration limit, every joint (deg/s^2)"
    )
    approach_height: float = setting(
        0.04, lo=0.01, hi=0.2, doc="the tool stops this far above a part before descending (m)"
    )
    release_height: float = setting(
        0.06, lo=0.01, hi=0.3, doc="cup face above a bin's rim when the part is released (m)"
    )
    grasp_timeout: float = setting(
        0.3, lo=0.02, hi=2.0, doc="longest wait for the vacuum to report a seal (s)"
    )
    release_time: float = setting(
        0.06, lo=0.0, hi=1.0, doc="wait after venting before the arm moves away (s)"
    )
    seal_force: float = setting(
        1.0, lo=0.05, hi=5.0, doc="cup contact force read as a sealed, holding cup (N)"
    )
    settle_tolerance: float = setting(
        0.001, lo=1e-5, hi=0.05, doc="largest joint error when a motion counts as done (rad)"
    )
    settle_timeout: float = setting(
        1.0, lo=0.05, hi=10.0, doc="longest wait for the joints to settle after a motion (s)"
    )
    ik_tolerance: float = setting(
        1e-4, lo=1e-7, hi=1e-2, doc="IK position tolerance (m); orientation tolerance x10 rad"
    )
    ik_max_iterations: int = setting(60, lo=1, hi=1000, doc="IK iterations before giving up")
