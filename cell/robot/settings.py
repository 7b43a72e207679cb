"""``RobotSettings``: the arm's motion limits and the pick-and-place parameters.

The scenario's ``[robot]`` section; units in each field's doc.
"""

from __future__ import annotations

from dataclasses import dataclass

from cell.config import check, setting

__all__ = ["RobotSettings"]


@dataclass(frozen=True)
class RobotSettings:
    """Limits and parameters of the robot.

    ``max_joint_accel`` defaults to 800 deg/s^2 (14 rad/s^2). Why: the UR5e publishes
    no joint acceleration limit, only torques (150 N m on the three big joints, 28 N m
    on the wrist), so the limit is set by what those torques can do for this arm.
    The binding joint is the shoulder lift, which must hold the stretched arm against
    gravity (about 60 N m) while accelerating it; at 800 deg/s^2 the largest torque any
    joint needs in the pick cycle stays near a third of its rating (``cell bench pick``
    reports it), which leaves the servos room to correct errors and carry a payload
    without saturating, and a 180-degree turn of the base takes 1.22 s.
    """

    max_joint_speed: float = setting(
        180.0, lo=1.0, hi=180.0, doc="joint speed limit, every joint (deg/s; UR5e: 180)"
    )
    max_joint_accel: float = setting(
        800.0, lo=10.0, hi=1500.0, doc="joint acceleration limit, every joint (deg/s^2)"
    )
    approach_height: float = setting(
        0.025, lo=0.01, hi=0.2,
        doc="the cup stops this far above a part before descending, and lifts it as far (m)"
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
        0.001, lo=1e-5, hi=0.05, doc="largest joint error when the cup reaches a part (rad)"
    )
    via_tolerance: float = setting(
        0.005, lo=1e-5, hi=0.1,
        doc="largest joint error at a via point (above a part, above a bin, HOME) (rad)",
    )
    settle_timeout: float = setting(
        1.0, lo=0.05, hi=10.0, doc="longest wait for the joints to settle after a motion (s)"
    )
    ik_tolerance: float = setting(
        1e-4, lo=1e-5, hi=1e-2,
        doc="IK position tolerance (m; the solver settles 2-5 um off: its posture task); orientation x10 rad",
    )
    ik_max_iterations: int = setting(60, lo=1, hi=1000, doc="IK iterations before giving up")

    def __post_init__(self) -> None:
        check(self, "robot")  # every field, however the object was made
