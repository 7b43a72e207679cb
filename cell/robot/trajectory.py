"""Time scaling of straight joint-space segments within speed and acceleration limits.

A segment goes from rest at ``q0`` to rest at ``q1`` along the straight line
``q(s) = q0 + s (q1 - q0)``, ``s`` in [0, 1]. With box limits ``|qd_i| <= v_i`` and
``|qdd_i| <= a_i`` the limits on the path speed are ``sd <= min_i v_i / |dq_i|`` and
``|sdd| <= min_i a_i / |dq_i|``, and the time-optimal profile of ``s`` is bang-bang in
acceleration: a trapezoid, or a triangle when the top speed is never reached
(Kunz & Stilman, "Time-optimal trajectory generation for path following with bounded
acceleration and velocity", RSS 2012, for a straight path). All joints move in step
and arrive together. Angles in rad, times in s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from cell.errors import RobotError
from cell.robot._checks import finite

__all__ = ["Segment", "Setpoint", "min_time", "plan_segment"]


def _profile_limits(dq: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> tuple[float, float]:
    moving = np.abs(dq) > 1e-12
    if not moving.any():
        return np.inf, np.inf
    sd = float(np.min(vmax[moving] / np.abs(dq[moving])))
    sdd = float(np.min(amax[moving] / np.abs(dq[moving])))
    return sd, sdd


def _duration(sd: float, sdd: float) -> tuple[float, float]:
    """Total time and acceleration time of the s-profile from 0 to 1."""
    if not np.isfinite(sd):
        return 0.0, 0.0
    if sd * sd / sdd >= 1.0:  # triangle: the top speed is never reached
        ta = float(np.sqrt(1.0 / sdd))
        return 2 * ta, ta
    ta = sd / sdd
    return ta + 1.0 / sd, ta


def min_time(q0: np.ndarray, q1: np.ndarray, vmax, amax) -> float:
    """Shortest time (s) to go from rest at ``q0`` to rest at ``q1`` along the straight
    joint-space line under per-joint limits ``vmax`` (rad/s) and ``amax`` (rad/s^2)."""
    q0, q1 = _joints("q0", q0), _joints("q1", q1)
    if q0.shape != q1.shape:
        raise RobotError(f"min_time: q0 {q0} and q1 {q1} must be the same shape")
    dq = q1 - q0
    v, a = _limit("vmax", vmax, dq.shape), _limit("amax", amax, dq.shape)
    return _duration(*_profile_limits(dq, v, a))[0]


def _joints(name: str, q: object) -> np.ndarray:
    """Joint angles as a finite float64 vector; ``RobotError`` naming ``name`` otherwise."""
    try:
        arr = np.array(q, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.full(1, np.nan)
    if arr.ndim != 1 or not np.isfinite(arr).all():
        raise RobotError(f"argument {name!r}: expected finite joint angles (rad), got {q!r}")
    return arr


def _limit(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
    """A per-joint limit (a number, or one per joint) broadcast to ``shape``: finite and
    above 0, else ``RobotError`` naming ``name``."""
    try:
        arr = np.broadcast_to(np.asarray(value, dtype=np.float64), shape)
    except (TypeError, ValueError):
        raise RobotError(f"argument {name!r}: expected a number or {shape[0]} numbers, "
                          f"got {value!r}") from None
    if not (np.isfinite(arr).all() and (arr > 0).all()):
        raise RobotError(f"argument {name!r}: limits must be finite and above 0, got {value!r}")
    return arr


class Setpoint(NamedTuple):
    """Where a :class:`Segment` is at one time: joint positions ``q`` (rad), velocities
    ``qd`` (rad/s) and accelerations ``qdd`` (rad/s^2), (6,) each."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


@dataclass(frozen=True)
class Segment:
    """A rest-to-rest straight joint motion, time-optimal under the limits.

    From ``q0`` to ``q1`` (rad, (6,) each) along the path q0 + s (q1 - q0), s from 0 to 1:
    ``duration`` (s), ``t_accel`` the time (s) spent speeding up (and as long slowing
    down), ``sd_max`` the path's speed limit (1/s; not reached when the profile is a
    triangle, ``t_accel`` half the duration) and ``sdd_max`` its acceleration (1/s^2).
    ``sample(t)`` gives the commanded position (rad), velocity (rad/s) and acceleration
    (rad/s^2) at time ``t`` from the start (clamped to the segment).
    """

    q0: np.ndarray
    q1: np.ndarray
    duration: float
    t_accel: float
    sd_max: float
    sdd_max: float

    def sample(self, t: float) -> Setpoint:
        """The :class:`Setpoint` at time ``t`` (s; before 0 the start, after the end the goal)."""
        t = finite("t", t, RobotError)
        dq = self.q1 - self.q0
        end, ta, a = self.duration, self.t_accel, self.sdd_max
        if end <= 0.0 or t >= end:
            return Setpoint(self.q1.copy(), np.zeros_like(dq), np.zeros_like(dq))
        t = max(t, 0.0)
        top = a * ta  # top path speed (reached or not)
        if t < ta:
            s, sd, sdd = 0.5 * a * t * t, a * t, a
        elif t <= end - ta:
            s, sd, sdd = 0.5 * a * ta * ta + top * (t - ta), top, 0.0
        else:
            r = end - t
            s, sd, sdd = 1.0 - 0.5 * a * r * r, a * r, -a
        return Setpoint(self.q0 + s * dq, sd * dq, sdd * dq)


def plan_segment(q0: np.ndarray, q1: np.ndarray, vmax, amax) -> Segment:
    """The time-optimal rest-to-rest :class:`Segment` from ``q0`` to ``q1`` (rad)
    under per-joint speed ``vmax`` (rad/s) and acceleration ``amax`` (rad/s^2) limits
    (scalars or arrays). Raises ``RobotError`` for non-finite input or limits <= 0."""
    q0, q1 = _joints("q0", q0), _joints("q1", q1)
    if q0.shape != q1.shape:
        raise RobotError(f"plan_segment: q0 {q0} and q1 {q1} must be finite, same shape")
    v, a = _limit("vmax", vmax, q0.shape), _limit("amax", amax, q0.shape)
    sd, sdd = _profile_limits(q1 - q0, v, a)
    duration, ta = _duration(sd, sdd)
    return Segment(q0, q1, duration, ta, sd, sdd)
