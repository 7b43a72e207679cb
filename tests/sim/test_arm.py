"""The arm model: DH kinematics, names, limits, servos, home pose, wrist camera."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from cell.errors import SimError
from cell.sim import layout
from cell.sim.arm import (
    DH,
    EFFORT,
    HOME,
    JOINT_NAMES,
    SPEED_LIMIT,
    TOOL_LENGTH,
    WRIST_CAMERA_FOVY,
    add_arm,
    build_arm,
)


def _dh_flange(q: np.ndarray) -> np.ndarray:
    """Reference forward kinematics: standard DH, T_i = Rz(q) Tz(d) Tx(a) Rx(alpha)."""
    T = np.eye(4)
    for qi, (d, a, alpha) in zip(q, DH, strict=True):
        ct, st, ca, sa = np.cos(qi), np.sin(qi), np.cos(alpha), np.sin(alpha)
        T = T @ np.array([[ct, -st * ca, st * sa, a * ct],
                          [st, ct * ca, -ct * sa, a * st],
                          [0, sa, ca, d],
                          [0, 0, 0, 1]])
    return T


def _site_pose(m, d, name):
    T = np.eye(4)
    T[:3, :3] = d.site(name).xmat.reshape(3, 3)
    T[:3, 3] = d.site(name).xpos
    return T


def _arm_with_floor():
    spec = mujoco.MjSpec()
    spec.option.timestep = layout.TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.1], pos=[0, 0, -0.01])
    add_arm(spec)
    m = spec.compile()
    return m, mujoco.MjData(m)


def test_flange_matches_dh_reference_over_random_configurations():
    m = build_arm().compile()
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    for _ in range(200):
        q = rng.uniform(m.jnt_range[:, 0], m.jnt_range[:, 1])
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        T_dh = _dh_flange(q)
        T_mj = _site_pose(m, d, "flange")
        assert np.abs(T_mj[:3, 3] - T_dh[:3, 3]).max() < 1e-6
        assert np.abs(T_mj[:3, :3] - T_dh[:3, :3]).max() < 1e-6
        tcp = _site_pose(m, d, "tcp")
        expected = T_dh[:3, 3] + TOOL_LENGTH * T_dh[:3, 2]
        assert np.abs(tcp[:3, 3] - expected).max() < 1e-6


def test_joints_limits_and_actuators_are_those_of_a_ur5e():
    m = build_arm().compile()
    assert tuple(m.joint(i).name for i in range(m.njnt)) == JOINT_NAMES
    assert m.body(m.jnt_bodyid[0]).parentid[0] == m.body("base").id
    for i, name in enumerate(JOINT_NAMES):
        assert m.actuator(name).trnid[0] == m.joint(name).id
        lo, hi = m.jnt_actfrcrange[i]
        assert (lo, hi) == (-EFFORT[i], EFFORT[i])
        assert m.actuator(f"{name}_vel").ctrlrange[1] == pytest.approx(SPEED_LIMIT)
    assert np.allclose(m.jnt_range[2], [-np.pi, np.pi])
    assert np.allclose(m.jnt_range[[0, 1, 3, 4, 5]], [-2 * np.pi, 2 * np.pi])
    assert m.actuator("suction").trntype[0] == mujoco.mjtTrn.mjTRN_BODY
    assert 10.0 < sum(m.body_mass) < 25.0  # UR5e: 20.6 kg with its base


def test_unknown_tool_is_an_error_that_lists_the_valid_ones():
    with pytest.raises(SimError, match="gripper.*valid: suction"):
        build_arm(tool="gripper")


def test_add_arm_prefixes_names_and_keeps_the_standalone_spec_usable():
    m, _ = _arm_with_floor()
    for name in ("arm/tcp", "arm/flange"):
        assert m.site(name).id >= 0
    assert m.camera("arm/wrist_camera").id >= 0
    assert m.actuator("arm/shoulder_pan").id >= 0
    assert m.actuator("arm/suction").id >= 0
    assert m.sensor("arm/suction_touch").id >= 0


def test_servos_hold_home_against_gravity():
    m, d = _arm_with_floor()
    qadr = [m.joint(f"arm/{n}").qposadr[0] for n in JOINT_NAMES]
    d.qpos[qadr] = HOME
    for n, q in zip(JOINT_NAMES, HOME, strict=True):
        d.ctrl[m.actuator(f"arm/{n}").id] = q
    mujoco.mj_step(m, d, 1000)  # 2 s
    assert np.abs(d.qpos[qadr] - HOME).max() < 1e-4
    assert np.abs(d.qvel[:6]).max() < 1e-3


def test_home_keeps_the_arm_out_of_the_overhead_camera_view():
    m, d = _arm_with_floor()
    d.qpos[:6] = HOME
    mujoco.mj_forward(m, d)
    cam = layout.PICK_ZONE + np.array([0, 0, layout.OVERHEAD_CAMERA_HEIGHT])
    tan_v = np.tan(np.deg2rad(20.0))
    tan_h = tan_v * 640 / 480
    for g in range(m.ngeom):
        if m.geom_bodyid[g] == 0:
            continue
        c, r = d.geom_xpos[g], m.geom_rbound[g]
        h = cam[2] - c[2]
        if h <= 0:
            continue  # above the camera
        # the geom's bounding sphere must lie outside the view pyramid
        assert abs(c[0] - cam[0]) - r > tan_h * h or abs(c[1] - cam[1]) - r > tan_v * h, (
            m.geom(g).name
        )


def test_wrist_camera_looks_along_the_tool_axis_and_misses_the_cup():
    m = build_arm().compile()
    d = mujoco.MjData(m)
    d.qpos[:] = HOME
    mujoco.mj_forward(m, d)
    R_cam = d.cam("wrist_camera").xmat.reshape(3, 3)
    tool_z = d.site("tcp").xmat.reshape(3, 3)[:, 2]
    assert np.dot(-R_cam[:, 2], tool_z) > 0.999  # MuJoCo cameras look along -z
    # every point of the cup's rim lies outside the camera's (vertical) field of view
    rim = [d.site("tcp").xpos + 0.01 * np.array([np.cos(a), np.sin(a), 0.0])
           for a in np.linspace(0, 2 * np.pi, 16)]
    half = np.deg2rad(WRIST_CAMERA_FOVY / 2)
    for p in rim:
        v = R_cam.T @ (p - d.cam("wrist_camera").xpos)
        assert abs(v[1]) / -v[2] > np.tan(half)
