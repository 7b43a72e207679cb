"""The catalogue's geometry helpers: a kind's yaw error modulo its symmetry (one rule for
the sort report, the vision bench and the sweeps) and its half diagonal."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cell.catalogue import KINDS

_ANGLE = st.floats(-20.0, 20.0, allow_nan=False)
_TURNED = [k for k in KINDS.values() if k.symmetry > 0]


@pytest.mark.parametrize("kind", [k.name for k in KINDS.values() if k.symmetry == 0])
def test_a_round_part_has_no_yaw_error(kind):
    assert KINDS[kind].yaw_error(1.0, 0.0) is None


@given(st.sampled_from(_TURNED), _ANGLE, _ANGLE, st.integers(-5, 5))
def test_yaw_error_is_the_least_angle_modulo_the_symmetry(kind, a, b, turns):
    period = 2 * math.pi / kind.symmetry
    err = kind.yaw_error(a, b)
    assert 0.0 <= err <= period / 2 + 1e-12
    assert err == pytest.approx(kind.yaw_error(b, a), abs=1e-9)
    assert err == pytest.approx(kind.yaw_error(a + turns * period, b), abs=1e-9)
    # a brute-force check: the smallest |a - b + k period| over k
    best = min(abs(a - b + k * period) for k in range(-200, 201))
    assert err == pytest.approx(best, abs=1e-9)


def test_yaw_error_examples():
    assert math.degrees(KINDS["hex_nut"].yaw_error(math.radians(61), 0.0)) == pytest.approx(1.0)
    assert math.degrees(KINDS["bolt"].yaw_error(math.radians(179), 0.0)) == pytest.approx(1.0)
    assert math.degrees(KINDS["l_bracket"].yaw_error(math.radians(179), 0.0)) == pytest.approx(179.0)


def test_half_diagonal():
    k = KINDS["bolt"]
    assert k.half_diagonal == pytest.approx(0.5 * math.hypot(k.length, k.width))
