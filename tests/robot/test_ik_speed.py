"""The IK is geometry only: its answer does not depend on how fast the arm may move, and
a tolerance finer than the solver reaches is reported as such, not as out of reach."""

from __future__ import annotations

import numpy as np
import pytest

from cell.errors import IKError
from cell.robot.ik import ArmIK
from cell.robot.settings import RobotSettings
from cell.sim import layout
from cell.sim.arm import HOME

# pick-zone approach and grasp targets (a part on the belt, yawed), and a bin drop
_TARGETS = [
    (layout.PICK_ZONE + [0.006, 0.0, 0.107], 1.133),
    (layout.PICK_ZONE + [-0.098, -0.024, 0.108], 1.180),
    (layout.PICK_ZONE + [0.02, -0.01, 0.03], 0.4),
    (layout.BINS[next(iter(layout.BINS))] + [0, 0, 0.16], 0.0),
]


@pytest.fixture(scope="module")
def default_ik():
    return ArmIK()


@pytest.mark.parametrize("speed", [1.0, 2.5, 30.0])
def test_a_slow_arm_solves_what_the_default_solves_the_same_way(default_ik, speed):
    # (the IK's step limit once was the arm's speed limit x its step: at 2.5 deg/s or
    # less it ran out of iterations and every pick was filed as unreachable)
    slow = ArmIK(RobotSettings(max_joint_speed=speed, max_joint_accel=10.0))
    for p, yaw in _TARGETS:
        seed = default_ik.seed_towards(p, yaw, HOME)
        q_default = default_ik.solve(p, yaw, seed)
        q_slow = slow.solve(p, yaw, seed)
        np.testing.assert_allclose(q_slow, q_default, atol=1e-12)
        assert np.linalg.norm(slow.fk(q_slow)[0] - p) < 2e-4


def test_a_tolerance_finer_than_the_solver_reaches_is_not_called_out_of_reach():
    settings = RobotSettings()
    # (below the key's range since the solver settles 2-5 um off: forced, to test the message)
    object.__setattr__(settings, "ik_tolerance", 1e-7)
    ik = ArmIK(settings)
    p, yaw = _TARGETS[2]
    with pytest.raises(IKError, match="no convergence") as info:
        ik.solve(p, yaw, ik.seed_towards(p, yaw, HOME))
    msg = str(info.value)
    assert "not to the tolerance" in msg and "robot.ik_tolerance 1e-07 m" in msg
    assert "unreachable" not in msg and "blocked" not in msg


def test_a_target_held_off_by_a_limit_is_still_unreachable_or_blocked(default_ik):
    p = layout.PICK_ZONE - [0, 0, 0.05]  # inside the belt
    with pytest.raises(IKError, match="unreachable or blocked"):
        default_ik.solve(p, 0.0, default_ik.seed_towards(p, 0.0, HOME))
