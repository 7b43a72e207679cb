"""The UR5e-style arm with a suction tool, built in code as a ``mujoco.MjSpec``.

Kinematics follow the public UR5e DH parameters exactly (standard DH,
``T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``): body ``k`` carries the DH frame ``k-1``
and joint ``k`` turns about its local z. At ``q = 0`` the arm is stretched along -x
of ``base``; the ``flange`` site is DH frame 6. The root body ``base`` sits at the
identity pose, so pinocchio's ``buildModelFromMJCF`` (which drops the top body's
pose) reads the same kinematics as MuJoCo.

Geometry is primitive (cylinders, capsules) with the real link offsets (upper arm
0.138 m, forearm 0.007 m off the DH plane); masses are the published UR5e link
masses with rod/cylinder inertias. Each joint has, as a servo drive's cascade, a
position servo (``<joint>``, stiffness ``kp``), a velocity servo (``<joint>_vel``,
gain ``kv``) and a torque feed-forward input (``<joint>_ff``, N m): commanding a
reference position, velocity and the model's inverse-dynamics torque gives a PD law
with feed-forward; with the other two controls left at 0 it is an ordinary damped
position servo. Gravity is
compensated through the actuators (as a controller's model-based feed-forward), and
the total joint torque is clamped to the UR5e efforts (150/150/150/28/28/28 N m).

The suction tool: a housing on the flange, a bellows cup (geom ``cup``, drawn only)
whose lip is a ring of eight small spheres (robust multi-point contact), site ``tcp`` at the cup
face (``TOOL_LENGTH`` from the flange, on the flange z axis), an adhesion actuator
``suction`` on the tool body (ctrl 0..1, ``SUCTION_FORCE`` N at 1) and a touch sensor
``suction_touch`` (normal contact force on the lip, N) that plays the vacuum switch.
Parts move only through contact and adhesion forces.

The camera ``wrist_camera`` sits on the tool, ``WRIST_CAMERA_OFFSET`` m off the tool
axis, looking along the tool axis (+z of the flange), with the cup out of its view.

Geoms of the arm use ``contype=2, conaffinity=1``: they collide with ordinary world
geoms (contype 1) but not with each other.

``build_arm(flange_board=True)`` (``add_arm`` too) mounts the eye-to-hand calibration
plate of ``cell.sim.flange_board`` on the tool; without it the arm is as described here.
"""

from __future__ import annotations

import mujoco
import numpy as np

from cell.errors import SimError
from cell.sim import layout
from cell.sim.flange_board import add_flange_board

__all__ = [
    "DH",
    "EFFORT",
    "HOME",
    "JOINT_NAMES",
    "JOINT_RANGE",
    "SPEED_LIMIT",
    "SUCTION_FORCE",
    "TOOLS",
    "TOOL_LENGTH",
    "WRIST_CAMERA_FOVY",
    "WRIST_CAMERA_OFFSET",
    "add_arm",
    "build_arm",
]

JOINT_NAMES = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")

# Standard DH rows (d, a, alpha) of the UR5e, metres and radians (Universal Robots).
DH = (
    (0.1625, 0.0, np.pi / 2),
    (0.0, -0.425, 0.0),
    (0.0, -0.3922, 0.0),
    (0.1333, 0.0, np.pi / 2),
    (0.0997, 0.0, -np.pi / 2),
    (0.0996, 0.0, 0.0),
)

# Real UR5e limits: +-360 deg on every joint but the elbow (+-180 deg, self-collision).
JOINT_RANGE = (
    (-2 * np.pi, 2 * np.pi),
    (-2 * np.pi, 2 * np.pi),
    (-np.pi, np.pi),
    (-2 * np.pi, 2 * np.pi),
    (-2 * np.pi, 2 * np.pi),
    (-2 * np.pi, 2 * np.pi),
)
SPEED_LIMIT = np.deg2rad(180.0)  # rad/s, every joint of the UR5e
EFFORT = (150.0, 150.0, 150.0, 28.0, 28.0, 28.0)  # N m

# Link masses (kg) of the UR5e, shoulder to wrist 3.
_MASS = (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)
_KP = (4000.0, 4000.0, 3000.0, 500.0, 500.0, 500.0)  # N m / rad
_KV = (400.0, 400.0, 250.0, 25.0, 25.0, 25.0)  # N m s / rad
_ARMATURE = (0.1, 0.1, 0.1, 0.05, 0.05, 0.05)  # reflected rotor inertia, kg m^2

TOOL_LENGTH = 0.12  # flange to cup face (tcp), metres
SUCTION_FORCE = 6.0  # adhesion force at full vacuum, N
_LIP_REACH = 0.002  # the vacuum pulls a part within this distance of the lip, m
WRIST_CAMERA_OFFSET = np.array([0.0, 0.065, 0.03])  # camera in the flange frame, metres
WRIST_CAMERA_FOVY = 50.0  # degrees

# HOME (rad): tool pointing straight down, TCP at about (0.295, 0.133, 0.30) m in the
# base frame, elbow up. Every link stays at y < 0.19 m, outside the overhead camera's
# view pyramid over PICK_ZONE (at belt level it sees y in [0.30, 0.60] m), and HOME
# lies on the short way (shoulder_pan through azimuth 0) from the pick zone to the
# metal and plastic bins, so a cycle pick -> bin -> HOME turns the base the least.
HOME = np.array([-np.pi, -2.05, 2.1, -1.62, -np.pi / 2, -np.pi / 2])

TOOLS = ("suction",)

_ARM_CONTYPE, _ARM_CONAFFINITY = 2, 1
_GREY = (0.72, 0.74, 0.76, 1.0)
_BLUE = (0.20, 0.42, 0.70, 1.0)
_DARK = (0.15, 0.15, 0.17, 1.0)


def _quat_rx(angle: float) -> list[float]:
    return [float(np.cos(angle / 2)), float(np.sin(angle / 2)), 0.0, 0.0]


def _geom(body, name: str, kind: str, size, *, fromto=None, pos=(0, 0, 0), rgba=_GREY):
    types = {"cyl": mujoco.mjtGeom.mjGEOM_CYLINDER, "cap": mujoco.mjtGeom.mjGEOM_CAPSULE,
             "box": mujoco.mjtGeom.mjGEOM_BOX, "sph": mujoco.mjtGeom.mjGEOM_SPHERE}
    g = body.add_geom(name=name, type=types[kind], size=list(size) + [0.0] * (3 - len(size)),
                      rgba=list(rgba), contype=_ARM_CONTYPE, conaffinity=_ARM_CONAFFINITY)
    if fromto is not None:
        g.fromto = list(fromto)
    else:
        g.pos = list(pos)
    return g


def _stiff(geom) -> None:
    """Rubber cup contact: its own friction, and stiff enough (2-step time constant) that
    the suction force cannot pull a light part through the lip."""
    geom.priority = 1
    geom.friction = [1.2, 0.01, 0.001]
    geom.solref = [2 * layout.TIMESTEP, 1.0]


def _set_inertia(body, mass: float, com, length: float, radius: float, axis: int) -> None:
    """A solid cylinder of ``length`` along body axis ``axis`` (0 x, 1 y, 2 z)."""
    along = mass * (3 * radius**2 + length**2) / 12.0
    across = mass * radius**2 / 2.0
    inertia = [along, along, along]
    inertia[axis] = across
    body.explicitinertial = True
    body.mass = mass
    body.ipos = list(com)
    body.inertia = inertia


def _add_joint(body, index: int) -> None:
    name = JOINT_NAMES[index]
    lo, hi = JOINT_RANGE[index]
    j = body.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1],
                       range=[lo, hi], armature=_ARMATURE[index])
    j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    j.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
    j.actfrcrange = [-EFFORT[index], EFFORT[index]]
    j.actgravcomp = True
    body.gravcomp = 1.0


def _add_links(base) -> mujoco.MjsBody:
    """Add the six links under ``base``; returns the wrist_3 body (DH frame 5)."""
    d1, a2, a3, d4, d5, d6 = DH[0][0], DH[1][1], DH[2][1], DH[3][0], DH[4][0], DH[5][0]
    _geom(base, "base_link", "cyl", (0.075, 0.045), pos=(0, 0, 0.045), rgba=_DARK)

    shoulder = base.add_body(name="shoulder_link")
    _add_joint(shoulder, 0)
    _set_inertia(shoulder, _MASS[0], (0, 0, 0.12), 0.12, 0.06, 2)
    _geom(shoulder, "shoulder_housing", "cyl", (0.06, 0.07), pos=(0, 0, 0.115), rgba=_BLUE)

    upper = shoulder.add_body(name="upper_arm_link", pos=[0, 0, d1], quat=_quat_rx(DH[0][2]))
    _add_joint(upper, 1)
    _set_inertia(upper, _MASS[1], (a2 / 2, 0, 0.138), abs(a2), 0.054, 0)
    _geom(upper, "shoulder_lift_housing", "cyl", (0.06, 0.07), pos=(0, 0, 0.07), rgba=_BLUE)
    _geom(upper, "upper_arm", "cap", (0.054,), fromto=(-0.02, 0, 0.138, a2 + 0.02, 0, 0.138))
    _geom(upper, "elbow_housing", "cyl", (0.05, 0.065), pos=(a2, 0, 0.075), rgba=_BLUE)

    fore = upper.add_body(name="forearm_link", pos=[a2, 0, 0])
    _add_joint(fore, 2)
    _set_inertia(fore, _MASS[2], (a3 / 2, 0, 0.007), abs(a3), 0.04, 0)
    _geom(fore, "forearm", "cap", (0.04,), fromto=(-0.03, 0, 0.007, a3 + 0.03, 0, 0.007))

    wrist1 = fore.add_body(name="wrist_1_link", pos=[a3, 0, 0])
    _add_joint(wrist1, 3)
    _set_inertia(wrist1, _MASS[3], (0, 0, d4 / 2), d4, 0.045, 2)
    _geom(wrist1, "wrist_1_housing", "cyl", (0.045, 0.07), pos=(0, 0, 0.07), rgba=_BLUE)

    wrist2 = wrist1.add_body(name="wrist_2_link", pos=[0, 0, d4], quat=_quat_rx(DH[3][2]))
    _add_joint(wrist2, 4)
    _set_inertia(wrist2, _MASS[4], (0, 0, d5 / 2), d5, 0.045, 2)
    _geom(wrist2, "wrist_2_housing", "cyl", (0.045, 0.05), pos=(0, 0, 0.045), rgba=_BLUE)

    wrist3 = wrist2.add_body(name="wrist_3_link", pos=[0, 0, d5], quat=_quat_rx(DH[4][2]))
    _add_joint(wrist3, 5)
    _set_inertia(wrist3, _MASS[5], (0, 0, d6 - 0.03), 0.06, 0.045, 2)
    _geom(wrist3, "wrist_3_housing", "cyl", (0.045, 0.035), pos=(0, 0, d6 - 0.035), rgba=_GREY)
    wrist3.add_site(name="flange", pos=[0, 0, d6], size=[0.005, 0, 0])
    return wrist3


def _add_suction_tool(spec: mujoco.MjSpec, wrist3) -> None:
    d6 = DH[5][0]
    tool = wrist3.add_body(name="tool", pos=[0, 0, d6])
    tool.explicitinertial = True
    tool.mass, tool.ipos, tool.inertia = 0.26, [0, 0, 0.045], [3.0e-4, 3.0e-4, 1.0e-4]
    tool.gravcomp = 1.0
    _geom(tool, "tool_housing", "cyl", (0.03, 0.035), pos=(0, 0, 0.035), rgba=_DARK)
    _geom(tool, "cup_stem", "cyl", (0.007, 0.0155), pos=(0, 0, 0.0855), rgba=_DARK)
    # camera bracket and camera body, off the tool axis
    cam_y, cam_z = WRIST_CAMERA_OFFSET[1], WRIST_CAMERA_OFFSET[2]
    _geom(tool, "camera_bracket", "box", (0.01, cam_y / 2, 0.006), pos=(0, cam_y / 2, 0.01),
          rgba=_DARK)
    _geom(tool, "camera_body", "box", (0.015, 0.015, 0.015), pos=(0, cam_y, cam_z - 0.017),
          rgba=_DARK)
    # MuJoCo cameras look along their -z: turn by pi about x to look along the tool's +z.
    tool.add_camera(name="wrist_camera", pos=list(WRIST_CAMERA_OFFSET), quat=_quat_rx(np.pi),
                    fovy=WRIST_CAMERA_FOVY)

    # The cup shares the tool body: pinocchio misplaces sites on nested fixed bodies.
    face = TOOL_LENGTH
    # The bellows is drawn but does not collide: only the lip touches a part, so a part
    # the vacuum pulls in askew rests on the lip and drops when vented (a rigid bellows
    # face next to the lip could wedge a thin washer).
    cup = _geom(tool, "cup", "cyl", (0.0095, 0.009), pos=(0, 0, face - 0.0015 - 0.009),
                rgba=(0.1, 0.1, 0.1, 1.0))
    cup.contype, cup.conaffinity = 0, 0
    lip_r, ring = 0.0015, 0.0062
    for k in range(8):
        ang = 2 * np.pi * k / 8
        g = _geom(tool, f"cup_lip{k}", "sph", (lip_r,),
                  pos=(ring * np.cos(ang), ring * np.sin(ang), face - lip_r),
                  rgba=(0.1, 0.1, 0.1, 1.0))
        _stiff(g)
        g.margin, g.gap = _LIP_REACH, _LIP_REACH  # detected within reach, active on touch
    tool.add_site(name="tcp", pos=[0, 0, face], size=[0.003, 0, 0])
    tool.add_site(name="suction_zone", type=mujoco.mjtGeom.mjGEOM_BOX,
                  pos=[0, 0, face - 0.002], size=[0.011, 0.011, 0.004], rgba=[0, 1, 0, 0.0])
    spec.add_sensor(name="suction_touch", type=mujoco.mjtSensor.mjSENS_TOUCH,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname="suction_zone")


def _add_servos(spec: mujoco.MjSpec) -> None:
    for i, name in enumerate(JOINT_NAMES):
        pos = spec.add_actuator(name=name, trntype=mujoco.mjtTrn.mjTRN_JOINT, target=name)
        pos.set_to_position(kp=_KP[i])
        pos.ctrlrange = list(JOINT_RANGE[i])
        pos.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        vel = spec.add_actuator(name=f"{name}_vel", trntype=mujoco.mjtTrn.mjTRN_JOINT,
                                target=name)
        vel.set_to_velocity(kv=_KV[i])
        vel.ctrlrange = [-SPEED_LIMIT, SPEED_LIMIT]
        vel.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        ff = spec.add_actuator(name=f"{name}_ff", trntype=mujoco.mjtTrn.mjTRN_JOINT,
                               target=name)
        ff.set_to_motor()
        ff.ctrlrange = [-EFFORT[i], EFFORT[i]]
        ff.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    if spec.body("tool") is not None:
        act = spec.add_actuator(name="suction", trntype=mujoco.mjtTrn.mjTRN_BODY,
                                target="tool")
        act.set_to_adhesion(SUCTION_FORCE)
        act.ctrlrange = [0.0, 1.0]


def build_arm(*, tool: str = "suction", flange_board: bool = False) -> mujoco.MjSpec:
    """The arm alone as a standalone spec: root body ``base`` at the identity pose.

    Parameters
    ----------
    tool : the end effector; only ``"suction"`` is built (no parallel gripper yet).
    flange_board : mount the calibration plate of ``cell.sim.flange_board`` on the tool
        (body ``flange_board``); off, the arm is built exactly as without the option.

    Raises ``SimError`` for an unknown tool, listing the valid ones.
    """
    if tool not in TOOLS:
        raise SimError(f"build_arm: unknown tool {tool!r}; valid: {', '.join(TOOLS)}")
    spec = mujoco.MjSpec()
    spec.modelname = "ur5e"
    spec.compiler.degree = False  # every angle in this module is in radians
    base = spec.worldbody.add_body(name="base")
    wrist3 = _add_links(base)
    _add_suction_tool(spec, wrist3)
    if flange_board:
        add_flange_board(spec, spec.body("tool"), contype=_ARM_CONTYPE,
                         conaffinity=_ARM_CONAFFINITY)
    _add_servos(spec)
    key = spec.add_key(name="home")
    key.qpos = list(HOME)
    key.ctrl = [v for q in HOME for v in (float(q), 0.0, 0.0)] + [0.0]
    return spec


def add_arm(world_spec: mujoco.MjSpec, *, tool: str = "suction", prefix: str = "arm/",
            flange_board: bool = False) -> None:
    """Attach a copy of the arm to ``world_spec`` at ``layout.ARM_BASE``.

    ``flange_board`` mounts the calibration plate (``build_arm``).
    Every name gets ``prefix`` (``arm/shoulder_pan``, ``arm/tcp``, ``arm/wrist_camera``).
    The arm's home keyframe is not carried over (keyframes are per model): start the
    arm with ``qpos`` and ``ctrl`` at ``HOME``.
    """
    arm = build_arm(tool=tool, flange_board=flange_board)
    for key in list(arm.keys):
        arm.delete(key)
    frame = world_spec.worldbody.add_frame(pos=list(map(float, layout.ARM_BASE)))
    frame.attach_body(arm.body("base"), prefix, "")
