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

from cell.errors import MotionError

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
    dq = np.asarray(q1, float) - np.asarray(q0, float)
    v = np.broadcast_to(np.asarray(vmax, float), dq.shape)
    a = np.broadcast_to(np.asarray(amax, float), dq.shape)
    return _duration(*_profile_limits(dq, v, a))[0]


class Setpoint(NamedTuple):
    """Where a :class:`Segment` is at one time: joint positions ``q`` (rad), velocities
    ``qd`` (rad/s) and accelerations ``qdd`` (rad/s^2), (6,) each."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


@dataclass(frozen=True)
class Segment:
    """A rest-to-rest straight joint motion, time-optimal under the limits.

    ``duration`` (s); ``sample(t)`` gives the commanded position (rad), velocity
    (rad/s) and acceleration (rad/s^2) at time ``t`` from the start (clamped to the
    segment).
    """

    q0: np.ndarray
    q1: np.ndarray
    duration: float
    t_accel: float
    sd_max: float
    sdd_max: float

    def sample(self, t: float) -> Setpoint:
        """The :class:`Setpoint` at time ``t`` (s; before 0 the start, after the end the goal)."""
        dq = self.q1 - self.q0
        T, ta, a = self.duration, self.t_accel, self.sdd_max
        if T <= 0.0 or t >= T:
            return Setpoint(self.q1.copy(), np.zeros_like(dq), np.zeros_like(dq))
        t = max(t, 0.0)
        top = a * ta  # top path speed (reached or not)
        if t < ta:
            s, sd, sdd = 0.5 * a * t * t, a * t, a
        elif t <= T - ta:
            s, sd, sdd = 0.5 * a * ta * ta + top * (t - ta), top, 0.0
        else:
            r = T - t
            s, sd, sdd = 1.0 - 0.5 * a * r * r, a * r, -a
        return Setpoint(self.q0 + s * dq, sd * dq, sdd * dq)


def plan_segment(q0: np.ndarray, q1: np.ndarray, vmax, amax) -> Segment:
    """The time-optimal rest-to-rest :class:`Segment` from ``q0`` to ``q1`` (rad)
    under per-joint speed ``vmax`` (rad/s) and acceleration ``amax`` (rad/s^2) limits
    (scalars or arrays). Raises ``MotionError`` for non-finite input or limits <= 0."""
    q0 = np.array(q0, dtype=np.float64)
    q1 = np.array(q1, dtype=np.float64)
    v = np.broadcast_to(np.asarray(vmax, float), q0.shape)
    a = np.broadcast_to(np.asarray(amax, float), q0.shape)
    if q0.shape != q1.shape or not (np.all(np.isfinite(q0)) and np.all(np.isfinite(q1))):
        raise MotionError(f"plan_segment: q0 {q0} and q1 {q1} must be finite, same shape")
    if np.any(v <= 0) or np.any(a <= 0):
        raise MotionError(f"plan_segment: limits must be positive, got vmax {v}, amax {a}")
    sd, sdd = _profile_limits(q1 - q0, v, a)
    T, ta = _duration(sd, sdd)
    return Segment(q0, q1, T, ta, sd, sdd)
