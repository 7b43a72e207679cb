"""``ArmDriver``: runs time-scaled joint motions on the simulated arm's servos.

Each physics step it commands the trajectory's position and velocity to the position
and velocity servos and the model's inverse-dynamics torque (pinocchio, gravity left
to the servos' compensation) to the feed-forward input, as an industrial servo drive
with feed-forward does. After a segment it holds the goal until every joint is within
``settle_tolerance`` (rad), or raises ``MotionError``. It reads only what a robot
controller reads: joint encoders (``qpos``/``qvel`` of the arm's joints).
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from cell.errors import MotionError, RobotError
from cell.robot._checks import finite, finite_vector
from cell.robot.kinematics import ArmKinematics
from cell.robot.settings import RobotSettings
from cell.robot.trajectory import Segment, plan_segment
from cell.sim.arm import JOINT_NAMES

__all__ = ["ArmDriver"]


class ArmDriver:
    """Drives the arm named ``prefix`` in ``model``/``data``; ``step(n)`` advances the
    simulation ``n`` physics steps (``World.step``). ``log``: when a list, every
    commanded sample ``(time, q, qd, qdd)`` is appended to it."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, step: Callable[[int], None],
                 settings: RobotSettings | None = None, *, kinematics: ArmKinematics | None = None,
                 prefix: str = "arm/", log: list | None = None) -> None:
        self.model, self.data, self._step = model, data, step
        self.settings = settings or RobotSettings()
        self.kin = kinematics or ArmKinematics()
        self.vmax = np.deg2rad(self.settings.max_joint_speed)
        self.amax = np.deg2rad(self.settings.max_joint_accel)
        self.dt = float(model.opt.timestep)
        names = [prefix + n for n in JOINT_NAMES]
        self._joints = np.array([model.joint(n).id for n in names])
        self._qadr = np.array([model.joint(n).qposadr[0] for n in names])
        self._dadr = np.array([model.joint(n).dofadr[0] for n in names])
        self._pos = np.array([model.actuator(n).id for n in names])
        self._vel = np.array([model.actuator(n + "_vel").id for n in names])
        self._ff = np.array([model.actuator(n + "_ff").id for n in names])
        self.log = log
        self.q_cmd = self.joint_positions()
        self.max_tracking_error = 0.0  # largest |encoder - reference| during motions, rad

    def joint_positions(self) -> np.ndarray:
        """Encoder reading (6,) rad."""
        return self.data.qpos[self._qadr].copy()

    def joint_velocities(self) -> np.ndarray:
        """Encoder velocity (6,) rad/s."""
        return self.data.qvel[self._dadr].copy()

    def command(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> None:
        """Send one servo set-point: position (rad), velocity (rad/s), acceleration
        (rad/s^2, turned into feed-forward torque); six finite numbers each."""
        self._send(*(finite_vector(name, v, 6, RobotError)
                     for name, v in (("q", q), ("qd", qd), ("qdd", qdd))))

    def _send(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> None:
        """:meth:`command` of checked set-points (the segments' own: one per physics step)."""
        ctrl = self.data.ctrl
        ctrl[self._pos] = q
        ctrl[self._vel] = qd
        ctrl[self._ff] = self.kin._feedforward(*(np.asarray(v, dtype=np.float64) for v in (q, qd, qdd)))
        self.q_cmd = np.array(q, dtype=np.float64)
        if self.log is not None:
            self.log.append((float(self.data.time), self.q_cmd, np.array(qd), np.array(qdd)))

    def sync(self) -> None:
        """Take the encoder reading as the last command when they differ by more than
        ``via_tolerance`` (someone else moved the arm), so the next segment starts
        where the arm is."""
        q = self.joint_positions()
        if np.abs(q - self.q_cmd).max() > self.settings.via_tolerance:
            self.q_cmd = q

    def plan(self, q_goal: np.ndarray) -> Segment:
        """The time-optimal segment from the last commanded position to ``q_goal``."""
        return plan_segment(self.q_cmd, q_goal, self.vmax, self.amax)

    def move(self, q_goal: np.ndarray, *, what: str = "goal",
             tolerance: float | None = None) -> Segment:
        """Run the segment to ``q_goal`` (rad) and wait until every joint is within
        ``tolerance`` rad of it (default ``settle_tolerance``; a via point may pass a
        looser one and let the servos finish converging during the next motion).

        Raises ``MotionError`` naming ``what`` if they do not settle in
        ``settle_timeout`` (blocked, or a servo saturated); ``RobotError`` for a goal
        that is not six finite numbers within the joint ranges."""
        seg = self.plan(self._goal(q_goal))
        self._follow(seg, None)
        self.settle(what=what, tolerance=tolerance)
        return seg

    def move_until(self, q_goal: np.ndarray, stop: Callable[[], bool], *, what: str = "goal") -> bool:
        """:meth:`move` to ``q_goal`` (rad), asking ``stop()`` after every physics step (a
        guarded move: a touch sensor, say): True when the arm settled at the goal; False
        when ``stop()`` said so first, the arm then commanded to hold where its joints are.
        Raises ``MotionError`` and ``RobotError`` as :meth:`move` does."""
        if self._follow(self.plan(self._goal(q_goal)), stop) and self.settle(what=what, stop=stop):
            return True
        self.command(self.joint_positions(), np.zeros(6), np.zeros(6))
        return False

    def _goal(self, q_goal: np.ndarray) -> np.ndarray:
        """``q_goal`` checked: six finite numbers (rad), each within its joint's range (a
        goal beyond it drove the joint to its stop and failed a second later as 'blocked
        or saturated')."""
        q = finite_vector("q_goal", q_goal, 6, RobotError)
        lo, hi = self.model.jnt_range[self._joints, 0], self.model.jnt_range[self._joints, 1]
        out = (q < lo - 1e-9) | (q > hi + 1e-9)
        if out.any():
            i = int(np.argmax(out))
            raise RobotError(f"argument 'q_goal': joint {JOINT_NAMES[i]} at {q[i]:.4f} rad is "
                             f"outside its range [{lo[i]:.4f}, {hi[i]:.4f}] rad")
        return q

    def _follow(self, seg: Segment, stop: Callable[[], bool] | None) -> bool:
        """Send ``seg``'s set-points, one per physics step (each step's is the reference at
        its start), then its end; False as soon as ``stop()`` is True."""
        for k in range(int(np.ceil(seg.duration / self.dt - 1e-9))):
            self._send(*seg.sample(k * self.dt))
            self._step(1)
            err = np.abs(self.joint_positions() - seg.sample((k + 1) * self.dt).q).max()
            self.max_tracking_error = max(self.max_tracking_error, float(err))
            if stop is not None and stop():
                return False
        self._send(seg.q1, np.zeros(6), np.zeros(6))
        return True

    def settle(self, *, what: str = "goal", tolerance: float | None = None,
               stop: Callable[[], bool] | None = None) -> bool:
        """Hold the last command until every joint is within ``tolerance`` rad (default
        ``settle_tolerance``) and nearly still (< 0.05 rad/s): True; False as soon as
        ``stop()`` is True (when given)."""
        s = self.settings
        tol = s.settle_tolerance if tolerance is None else tolerance
        err = np.inf
        for _ in range(int(np.ceil(s.settle_timeout / self.dt)) + 1):
            err = np.abs(self.joint_positions() - self.q_cmd).max()
            if err < tol and np.abs(self.joint_velocities()).max() < 0.05:
                return True
            self._step(1)
            if stop is not None and stop():
                return False
        raise MotionError(
            f"arm did not settle at {what} {np.round(self.q_cmd, 3).tolist()} rad within "
            f"{s.settle_timeout} s (joint error {err:.4f} rad): blocked or saturated")

    def wait(self, seconds: float) -> None:
        """Hold the last command for ``seconds`` (finite, >= 0) of simulated time."""
        seconds = finite("seconds", seconds, RobotError)
        if seconds < 0:
            raise RobotError(f"argument 'seconds': expected a time >= 0, got {seconds!r}")
        self._step(int(round(seconds / self.dt)))
