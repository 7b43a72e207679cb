"""Time scaling: limits never exceeded, the limiting joint saturates, exact arrival."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.errors import RobotError
from cell.robot.trajectory import min_time, plan_segment

VMAX, AMAX = np.pi, np.deg2rad(600.0)
_angles = st.lists(st.floats(-6.0, 6.0), min_size=6, max_size=6)


@settings(max_examples=60, deadline=None)
@given(_angles, _angles)
def test_commanded_samples_respect_both_limits_and_arrive(q0, q1):
    seg = plan_segment(q0, q1, VMAX, AMAX)
    dt = 0.002
    ts = np.arange(0.0, seg.duration + 4 * dt, dt)
    q = np.array([seg.sample(t).q for t in ts])
    qd = np.array([seg.sample(t).qd for t in ts])
    qdd = np.array([seg.sample(t).qdd for t in ts])
    assert np.abs(qd).max() <= VMAX * (1 + 1e-9)
    assert np.abs(qdd).max() <= AMAX * (1 + 1e-9)
    # the commanded positions themselves, differenced at the servo rate
    assert np.abs(np.diff(q, axis=0)).max() <= VMAX * dt * (1 + 1e-9)
    assert np.abs(np.diff(q, n=2, axis=0)).max() <= AMAX * dt * dt * (1 + 1e-6) + 1e-12
    assert np.allclose(q[-1], q1, atol=1e-12)
    assert np.allclose(q[0], q0, atol=1e-12)


def test_duration_is_the_single_joint_bound_of_the_limiting_joint():
    # A long move: trapezoid, the top speed is reached.
    seg = plan_segment([0.0, 0.0], [3.0, -1.0], VMAX, AMAX)
    assert seg.duration == pytest.approx(3.0 / VMAX + VMAX / AMAX)
    peak = max(np.abs(seg.sample(t).qd[0]) for t in np.linspace(0, seg.duration, 500))
    assert peak == pytest.approx(VMAX, rel=1e-6)
    # A short move: triangle, full acceleration, never at top speed.
    short = plan_segment([0.0], [0.1], VMAX, AMAX)
    assert short.duration == pytest.approx(2 * np.sqrt(0.1 / AMAX))
    assert min_time([0.0], [0.1], VMAX, AMAX) == pytest.approx(short.duration)
    assert plan_segment([1.0], [1.0], VMAX, AMAX).duration == 0.0


@pytest.mark.parametrize(("vmax", "amax", "culprit"), [
    (0.0, AMAX, "vmax"), (math.nan, AMAX, "vmax"), (math.inf, AMAX, "vmax"),
    (VMAX, math.nan, "amax"), (VMAX, math.inf, "amax"), (VMAX, -1.0, "amax"),
    ([1.0, 2.0], AMAX, "vmax"),
])
def test_bad_limits_are_a_robot_error_naming_them(vmax, amax, culprit):
    # (a NaN or infinite limit once gave a zero-time jump or NaN set-points)
    for plan in (plan_segment, min_time):
        with pytest.raises(RobotError, match=f"argument '{culprit}'"):
            plan([0.0], [1.0], vmax, amax)


def test_bad_joints_and_times_are_a_robot_error():
    with pytest.raises(RobotError, match="argument 'q1'"):
        plan_segment([0.0], [math.nan], VMAX, AMAX)
    with pytest.raises(RobotError, match="argument 't'"):
        plan_segment([0.0], [1.0], VMAX, AMAX).sample(math.nan)
