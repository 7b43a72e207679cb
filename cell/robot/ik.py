"""``ArmIK``: inverse kinematics of the arm with mink, collision-aware.

The IK works on its own MuJoCo model of the cell's fixed furniture (table, conveyor,
bins: the same builders as the simulated world, i.e. the cell's CAD) with the arm
attached at ``layout.ARM_BASE``; parts are not in it. Each solve iterates mink's
differential IK (Zakka, *mink: Python inverse kinematics based on MuJoCo*, 2024;
QP-based, Caron's *pink* formulation) with

- a ``FrameTask`` on the ``tcp`` site (position and orientation),
- a low-weight ``PostureTask`` towards the seed (keeps the solution on the seed's
  branch: elbow up, wrist the least turned),
- ``ConfigurationLimit`` (joint ranges), ``VelocityLimit`` (a fixed step of at most
  ``_IK_VMAX * _IK_DT`` = 0.63 rad per joint and iteration, which keeps each QP's
  linearisation local) and ``CollisionAvoidanceLimit`` (arm links and tool against
  table, conveyor and bins),

until the TCP is within ``ik_tolerance`` (and 10x that in radians) of the target.
Targets are "tool pointing down" poses: a TCP position and a yaw about world z.

The IK answers a geometric question only: its result does not depend on the scenario's
``max_joint_speed``/``max_joint_accel`` (how fast the arm may move is the trajectory's
business, ``cell.robot.trajectory``). Its step limit once was the arm's speed limit x
``_IK_DT``, so an arm slowed to 2.5 deg/s or less ran out of iterations on every pick.
The solve stalls a few micrometres from its target (the posture task's pull: 5e-6 m
is met in 4 iterations, 2e-6 m not in any number), so a finer ``ik_tolerance`` fails
every solve; the error then says "not to the tolerance", not "unreachable".
"""

from __future__ import annotations

import math
import time

import mink
import mujoco
import numpy as np

from cell.errors import IKError, RobotError
from cell.robot._checks import finite, finite_vector
from cell.robot.settings import RobotSettings
from cell.sim import layout
from cell.sim.arm import JOINT_NAMES, add_arm
from cell.sim.conveyor import add_conveyor
from cell.sim.fixtures import add_bins, add_table

__all__ = ["ArmIK", "down_rotation", "tool_yaw"]

_PREFIX = "arm/"
_ARM_LINKS = ("upper_arm", "elbow_housing", "forearm", "wrist_1_housing", "wrist_2_housing",
              "wrist_3_housing", "tool_housing", "camera_body", "camera_bracket")
_OBSTACLES = ("table", "belt", "conveyor_frame", "rail_left", "rail_right")
_IK_DT = 0.2  # s: the step of one differential-IK iteration
# rad/s: the IK's own velocity limit (180 deg/s, the UR5e's top speed and the default
# max_joint_speed, so default solves are unchanged): a joint moves at most 0.63 rad per
# iteration. Deliberately not RobotSettings.max_joint_speed (see the module docstring).
_IK_VMAX = np.pi
# an unconverged solve this near its target (m, rad: the default ik_tolerance) is
# reported as "not to the tolerance", not as out of reach or blocked
_NEAR_P, _NEAR_R = 1e-4, 1e-3
_INSIDE = 0.0005  # m: a cup sunk deeper into the furniture is no solution (resting on it is)


def down_rotation(yaw: float) -> np.ndarray:
    """``R_world_tool`` (3x3) of a tool pointing straight down (z = -world z) whose x axis
    points at heading ``yaw`` (rad) in the table plane."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


def tool_yaw(R_world_tool: np.ndarray) -> float:
    """Heading (rad) of the tool's x axis in the table plane."""
    return float(np.arctan2(R_world_tool[1, 0], R_world_tool[0, 0]))


def _wrap(angle: float) -> float:
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def _ik_spec() -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    add_table(spec)
    add_conveyor(spec)
    add_bins(spec)
    add_arm(spec)
    return spec


class ArmIK:
    """Collision-aware IK for tool-down targets. Not thread-safe (one model, one data).

    ``solve`` returns joint angles (6,) rad; ``fk`` gives the TCP pose of the IK model.
    ``stats`` holds the wall time (s) and iteration count of every solve.
    """

    def __init__(self, settings: RobotSettings | None = None) -> None:
        self.settings = settings or RobotSettings()
        self.model = _ik_spec().compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._qadr = np.array([m.joint(_PREFIX + n).qposadr[0] for n in JOINT_NAMES])
        if not np.array_equal(self._qadr, np.arange(6)) or m.nq != 6:
            raise RobotError("IK model: expected the arm's 6 joints as the only coordinates")
        self.configuration = mink.Configuration(m)
        self.task = mink.FrameTask(_PREFIX + "tcp", "site", position_cost=1.0,
                                   orientation_cost=0.5, lm_damping=1e-6)
        self.posture = mink.PostureTask(m, cost=1e-3)
        obstacles = [g for g in _OBSTACLES + tuple(f"bin_{b}_wall{i}" for b in layout.BINS
                                                   for i in range(4))]
        links = [_PREFIX + g for g in _ARM_LINKS]
        self.limits = [
            mink.ConfigurationLimit(m),
            mink.VelocityLimit(m, {_PREFIX + n: _IK_VMAX for n in JOINT_NAMES}),
            mink.CollisionAvoidanceLimit(m, geom_pairs=[(links, obstacles)],
                                         minimum_distance_from_collisions=0.01,
                                         collision_detection_distance=0.05),
        ]
        self._cup_id = m.geom(_PREFIX + "cup").id
        self._link_ids = {m.geom(g).id for g in links} | {self._cup_id}
        self._obstacle_ids = {m.geom(g).id for g in obstacles}
        self.stats: list[tuple[float, int]] = []

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """TCP position (3,) m and ``R_world_tool`` (3, 3) at joint angles ``q``."""
        d = self.data
        d.qpos[:] = finite_vector("q", q, 6, RobotError)
        mujoco.mj_kinematics(self.model, d)
        site = d.site(_PREFIX + "tcp")
        return site.xpos.copy(), site.xmat.reshape(3, 3).copy()

    def collides(self, q: np.ndarray, *, clearance: float = 0.0) -> str | None:
        """Name of the first arm link nearer than ``clearance`` (m, finite) to the furniture
        at ``q``, or None."""
        clearance = finite("clearance", clearance, RobotError)
        m, d = self.model, self.data
        d.qpos[:] = finite_vector("q", q, 6, RobotError)
        mujoco.mj_kinematics(m, d)
        fromto = np.zeros(6)
        for a in self._link_ids:
            for b in self._obstacle_ids:
                dist = mujoco.mj_geomDistance(m, d, a, b, clearance + 0.05, fromto)
                if dist < clearance:
                    return f"{m.geom(a).name} vs {m.geom(b).name}"
        return None

    def base_turn(self, q_ref: np.ndarray, position: np.ndarray) -> float:
        """How far (rad, in (-pi, pi]) the base turns from the tool-down pose ``q_ref`` to a
        tool-down pose at ``position`` (m), the arm keeping its shape's branch. Not the
        change of the tool's azimuth: the tool point sits off the arm's plane by the
        wrist's offset (d4, 133 mm on a UR5e), so its azimuth is the base angle plus
        ``delta``, ``r sin(delta) = offset`` at radius ``r``; 5-9 degrees apart between HOME
        and the pick zone, which every pick added to the wrist's turn before."""
        p_ref, _ = self.fk(q_ref)
        position = finite_vector("position", position, 3, RobotError)
        r_ref, r = math.hypot(p_ref[0], p_ref[1]), math.hypot(position[0], position[1])
        delta_ref = _wrap(math.atan2(p_ref[1], p_ref[0]) - q_ref[0])
        offset = r_ref * math.sin(delta_ref)
        if r <= abs(offset):  # (no tool-down pose reaches inside the offset's circle)
            return _wrap(math.atan2(position[1], position[0]) - math.atan2(p_ref[1], p_ref[0]))
        delta = math.asin(offset / r)
        if math.cos(delta_ref) < 0:  # the same branch: the arm reaching over its base
            delta = math.pi - delta
        return _wrap(math.atan2(position[1], position[0]) - delta - q_ref[0])

    def seed_towards(self, position: np.ndarray, yaw: float, q_ref: np.ndarray) -> np.ndarray:
        """A seed (6,) rad for a tool-down target: ``q_ref`` with the base turned as
        :meth:`base_turn` says and the wrist by what is left of the change of yaw,
        wrapped to (-pi, pi] (the wrist turns the least); arm shape kept."""
        _, R_ref = self.fk(q_ref)
        yaw = finite("yaw", yaw, RobotError)
        turn = self.base_turn(q_ref, position)
        d_yaw = _wrap(yaw - tool_yaw(R_ref))
        q = np.array(q_ref, dtype=np.float64)
        q[0] += turn
        q[5] += turn - d_yaw  # tool down: yaw = q1 - q6 + const
        lo, hi = self.model.jnt_range[:, 0], self.model.jnt_range[:, 1]
        for i in (0, 5):
            if q[i] > hi[i]:
                q[i] -= 2 * np.pi
            elif q[i] < lo[i]:
                q[i] += 2 * np.pi
        return q

    def solve(self, position: np.ndarray, yaw: float, seed: np.ndarray, *,
              what: str = "target") -> np.ndarray:
        """Joint angles (6,) rad that put the TCP at ``position`` (world, m), tool down
        with heading ``yaw`` (rad), starting from ``seed`` (6,) rad.

        Raises ``IKError`` naming ``what`` and the target when the solver does not reach
        the tolerance in ``ik_max_iterations``: "unreachable or blocked" when it stops
        far from the target, "not to the tolerance" when it came within ``_NEAR_P`` m
        and ``_NEAR_R`` rad (a tolerance finer than the solver reaches), or a solution
        that sinks the cup into the furniture. Independent of the arm's speed limits. A
        caller's bug is a ``RobotError`` (not an ``IKError``, which the sort job files as an
        unreachable part): numbers that are not finite, a seed outside the joint ranges.
        """
        s = self.settings
        position = finite_vector("position", position, 3, RobotError)
        yaw = finite("yaw", yaw, RobotError)
        seed = finite_vector("seed", seed, 6, RobotError)
        lo, hi = self.model.jnt_range[:, 0], self.model.jnt_range[:, 1]
        if ((seed < lo - 1e-9) | (seed > hi + 1e-9)).any():  # (the QP then has no solution)
            i = int(np.argmax((seed < lo - 1e-9) | (seed > hi + 1e-9)))
            raise RobotError(f"argument 'seed': joint {JOINT_NAMES[i]} at {seed[i]:.4f} rad is "
                             f"outside its range [{lo[i]:.4f}, {hi[i]:.4f}] rad")
        t0 = time.perf_counter()
        reach = np.linalg.norm(position[:2] - layout.ARM_BASE[:2])
        if reach > 0.95:
            raise IKError(f"IK for {what} at {np.round(position, 4).tolist()} m: out of the "
                          f"arm's reach ({reach:.3f} m from the base axis, UR5e: 0.85 m)")
        if position[2] < -0.05:
            raise IKError(f"IK for {what} at {np.round(position, 4).tolist()} m: below the "
                          f"table (z {position[2]:.3f} m; the lowest the tool goes is -0.05 m)")
        cfg = self.configuration
        cfg.update(np.asarray(seed, dtype=np.float64))
        target = mink.SE3.from_rotation_and_translation(
            mink.SO3.from_matrix(down_rotation(yaw)), position)
        self.task.set_target(target)
        self.posture.set_target(cfg.q)
        tasks = [self.task, self.posture]
        tol_p, tol_r = s.ik_tolerance, 10 * s.ik_tolerance
        err = self.task.compute_error(cfg)
        it = 0
        while np.linalg.norm(err[:3]) > tol_p or np.linalg.norm(err[3:]) > tol_r:
            if it >= s.ik_max_iterations:
                self.stats.append((time.perf_counter() - t0, it))
                e_p, e_r = float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))
                if e_p < _NEAR_P and e_r < _NEAR_R:
                    why = (f"reached to within {1e6 * e_p:.2f} um and {e_r:.2g} rad, but not "
                           f"to the tolerance (robot.ik_tolerance {tol_p:g} m, {tol_r:g} "
                           "rad): the target is in reach; the tolerance is finer than the "
                           "solver gets (it stalls a few um off) in robot.ik_max_iterations "
                           f"{s.ik_max_iterations}")
                else:
                    why = (f"position error {1000 * e_p:.2f} mm, orientation error "
                           f"{e_r:.4f} rad: unreachable or blocked by joint or collision "
                           "limits")
                raise IKError(
                    f"IK for {what} at {np.round(position, 4).tolist()} m, yaw "
                    f"{yaw:.3f} rad: no convergence in {it} iterations ({why})")
            try:
                v = mink.solve_ik(cfg, tasks, _IK_DT, "daqp", limits=self.limits)
            except mink.NoSolutionFound as exc:
                raise IKError(f"IK for {what} at {np.round(position, 4).tolist()} m: "
                              f"the QP has no solution ({exc})") from None
            cfg.integrate_inplace(v, _IK_DT)
            err = self.task.compute_error(cfg)
            it += 1
        self.stats.append((time.perf_counter() - t0, it))
        inside = self._cup_inside(cfg.q)
        if inside is not None:  # (the cup is no link the QP keeps clear: it grasps on the belt)
            raise IKError(f"IK for {what} at {np.round(position, 4).tolist()} m: the cup would "
                          f"be {1000 * inside[1]:.1f} mm inside the {inside[0]}")
        return cfg.q.copy()

    def solve_pose(self, T_base_tcp: np.ndarray, seed: np.ndarray, *, tolerance: float,
                   iterations: int, limits: list | None = None, what: str = "pose") -> np.ndarray:
        """Joint angles (6,) rad that put the TCP at ``T_base_tcp`` (4x4, m, any
        orientation), from ``seed`` (6,) rad, with this IK's tasks (the posture task keeps
        the arm on the seed's branch) and ``limits`` (None: this IK's, collisions included),
        to within ``tolerance`` m and 10x that in rad. Raises ``IKError`` naming ``what``
        when it does not converge in ``iterations`` or the QP has no solution. No reach,
        furniture or argument checks: for poses a program draws (calibration views, the
        flange board's poses), not a user's targets (:meth:`solve`)."""
        cfg = self.configuration
        cfg.update(np.asarray(seed, dtype=np.float64))
        self.task.set_target(mink.SE3.from_matrix(T_base_tcp))
        self.posture.set_target(cfg.q)
        where = f"{what} at {np.round(T_base_tcp[:3, 3], 3).tolist()} m"
        for _ in range(iterations):
            err = self.task.compute_error(cfg)
            if np.linalg.norm(err[:3]) <= tolerance and np.linalg.norm(err[3:]) <= 10 * tolerance:
                return cfg.q.copy()
            try:
                v = mink.solve_ik(cfg, [self.task, self.posture], _IK_DT, "daqp",
                                  limits=self.limits if limits is None else limits)
            except mink.NoSolutionFound as exc:
                raise IKError(f"{where}: the IK's QP has no solution ({exc})") from None
            cfg.integrate_inplace(v, _IK_DT)
        raise IKError(f"{where}: no convergence in {iterations} iterations (unreachable or "
                      "blocked)")

    def _cup_inside(self, q: np.ndarray) -> tuple[str, float] | None:
        """(obstacle, depth m) where the cup at ``q`` sinks more than ``_INSIDE`` into the
        furniture (table, belt, conveyor, rails, bin walls), or None."""
        m, d = self.model, self.data
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        fromto = np.zeros(6)
        for b in self._obstacle_ids:
            dist = mujoco.mj_geomDistance(m, d, self._cup_id, b, 0.01, fromto)
            if dist < -_INSIDE:
                return m.geom(b).name.removeprefix(_PREFIX), -dist
        return None
