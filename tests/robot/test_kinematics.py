"""pinocchio (controller model) against MuJoCo (simulator) on the same MJCF."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from cell.errors import RobotError
from cell.robot.kinematics import ArmKinematics
from cell.sim.arm import build_arm


@pytest.fixture(scope="module")
def models():
    m = build_arm().compile()
    return ArmKinematics(), m, mujoco.MjData(m)


@pytest.mark.parametrize("frame", ["tcp", "flange"])
def test_pose_and_jacobian_agree_with_mujoco_to_1e9(models, frame):
    kin, m, d = models
    rng = np.random.default_rng(1)
    sid = m.site(frame).id
    for _ in range(100):
        q = rng.uniform(m.jnt_range[:, 0], m.jnt_range[:, 1])
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        T = kin.pose(q, frame)
        assert np.abs(T[:3, 3] - d.site_xpos[sid]).max() < 1e-9
        assert np.abs(T[:3, :3] - d.site_xmat[sid].reshape(3, 3)).max() < 1e-9
        jp, jr = np.zeros((3, 6)), np.zeros((3, 6))
        mujoco.mj_jacSite(m, d, jp, jr, sid)
        assert np.abs(kin.jacobian(q, frame) - np.vstack([jp, jr])).max() < 1e-9


def test_feedforward_torque_is_mujocos_inverse_dynamics_without_gravity(models):
    kin, m, d = models
    m = build_arm().compile()
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    rng = np.random.default_rng(2)
    for _ in range(20):
        q, qd, qdd = rng.uniform(-3, 3, 6), rng.normal(size=6), rng.normal(size=6) * 5
        d.qpos[:], d.qvel[:] = q, qd
        mujoco.mj_forward(m, d)
        d.qacc[:] = qdd
        mujoco.mj_inverse(m, d)
        assert np.allclose(kin.feedforward_torque(q, qd, qdd), d.qfrc_inverse, atol=1e-5)


def test_unknown_frame_names_the_valid_ones(models):
    with pytest.raises(RobotError, match="valid: tcp, flange"):
        models[0].pose(np.zeros(6), "gripper")


def test_joint_vectors_that_are_not_six_finite_numbers_are_refused(models):
    # (pinocchio returned NaN poses, or raised a ValueError quoting its C++ source)
    kin = models[0]
    ok = np.zeros(6)
    for bad in (np.full(6, np.nan), np.zeros(5), np.array([0, 0, 0, 0, 0, np.inf])):
        with pytest.raises(RobotError, match="argument 'q'"):
            kin.pose(bad)
        with pytest.raises(RobotError, match="argument 'q'"):
            kin.jacobian(bad)
        with pytest.raises(RobotError, match="argument 'q'"):
            kin.feedforward_torque(bad, ok, ok)
    with pytest.raises(RobotError, match="argument 'qdd'"):
        kin.feedforward_torque(ok, ok, np.full(6, np.inf))


def test_a_frame_that_is_no_name_is_a_robot_error():
    """pose(q, frame=5) raised pinocchio's Boost.Python error."""
    with pytest.raises(RobotError, match="argument 'frame': expected a frame name"):
        ArmKinematics().pose(np.zeros(6), 5)
