"""Compiled yaw and reference point of a footprint for its kind (numba).

:func:`kind_yaw` is :func:`cell.vision.kind.footprint_yaw` (the nuts and the L bracket:
the n-th circular harmonic of the outline's chord directions, Mardia & Jupp,
*Directional Statistics*, 2000, ch. 3; the bolt: second moments, with the arithmetic of
``cv2.moments`` on the outline in float32 mm), :func:`bolt_point` the reference point of a bolt
(:func:`cell.vision._footprint.bolt_origin`), each in one call instead of a dozen numpy
operations. The outline's projections on
a direction are ``outline @ u`` as numpy's matrix product computes them (OpenBLAS:
``fma(x, u_x, y * u_y)``), so the results equal the numpy formulation's bit for bit
(``tests/vision/test_pose.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cell.vision._fma import fma

__all__: list[str] = []  # private to cell.vision

HEX_NUT, SQUARE_NUT, L_BRACKET, BOLT, RECTANGLE = 0, 1, 2, 3, 4  # kind codes of kind_yaw
CUT_GUARD = 6  # outline points next to a cut left out of the yaw (the contact's notch)
_L_TURN = math.radians(2.0)  # see _bracket_yaw
_BOLT_END_OFFSET = 0.0014  # body origin from the middle of the bolt's ends, towards the head



@njit(cache=True)
def _along(p, k, cx, cy, ux, uy):  # pragma: no cover (compiled)
    """(p[k] - (cx, cy)) @ (ux, uy), as numpy's matrix product rounds it."""
    return fma(p[k, 0] - cx, ux, (p[k, 1] - cy) * uy)


@njit(cache=True)
def flat_angle(p, n, step, kappa, iterations, skip_from, skip):  # pragma: no cover
    """Direction (rad) of the flats' normals of an n-fold outline ``p`` (N, 2), mod
    2*pi/n: see :func:`cell.vision.kind.footprint_yaw` (chords of ``step`` points; the
    chords spanning the ``skip`` points from ``skip_from`` on, cyclically, left out)."""
    m = p.shape[0]
    e = np.empty(m, np.complex128)  # exp(i * n * psi) of each chord p[k + step] - p[k]
    length = np.empty(m)
    mean = 0j
    for k in range(m):
        j = (k + step) % m
        # a chord spanning any of the skip points from skip_from on (cyclically) is left out
        r = (k - skip_from) % m
        if skip > 0 and (r < skip or r >= m - step):
            length[k] = 0.0
            e[k] = 0j
            continue
        dx, dy = p[j, 0] - p[k, 0], p[j, 1] - p[k, 1]
        length[k] = math.sqrt(dx * dx + dy * dy)
        u = complex(dx, dy) / max(length[k], 1e-300)
        w = 1.0 + 0j
        for _ in range(n):
            w *= u
        e[k] = w
        mean += length[k] * w
    for _ in range(iterations):
        unit = mean.conjugate() / max(abs(mean), 1e-300)
        new = 0j
        for k in range(m):
            new += length[k] * math.exp(kappa * ((e[k] * unit).real - 1.0)) * e[k]
        mean = new
    return math.atan2(mean.imag, mean.real) / n + math.pi / 2


@njit(cache=True)
def _nut_angle(p, n, kappa, cut):  # pragma: no cover (compiled)
    """:func:`flat_angle` of a nut's outline, reweighted twice, the chords over its last
    ``cut`` points (a cut between touching parts) and CUT_GUARD either side left out."""
    m = p.shape[0]
    skip = min(cut + 2 * CUT_GUARD, m // 2) if cut else 0
    return flat_angle(p, n, 5, kappa, 2, m - cut - CUT_GUARD, skip)


@njit(cache=True)
def _bracket_yaw(p, cx, cy, rect_angle):  # pragma: no cover (compiled)
    """Yaw of an L bracket: direction of its long leg, seen from the outer corner (see
    :func:`cell.vision.kind.footprint_yaw`)."""
    a = rect_angle
    off = (flat_angle(p, 4, 5, 2.0, 2, p.shape[0] - CUT_GUARD, 0) - a + math.pi / 4) % (
        math.pi / 2) - math.pi / 4
    if abs(off) > _L_TURN:
        a += off
    ux, uy = math.cos(a), math.sin(a)
    s_max = s_min = _along(p, 0, cx, cy, ux, uy)
    for k in range(1, p.shape[0]):
        s = _along(p, k, cx, cy, ux, uy)
        s_max, s_min = max(s_max, s), min(s_min, s)
    su = 1.0 if s_max > -s_min else -1.0
    return math.atan2(su * uy, su * ux)


@njit(cache=True)
def kind_yaw(p, cx, cy, rect_angle, code, n, cut):  # pragma: no cover (compiled)
    """Yaw (rad, in [0, 2*pi/n)) of a footprint (outline ``p`` (N, 2), centroid, minimum
    rectangle's angle) for a kind of n-fold symmetry: ``code`` HEX_NUT (a corner on +x),
    SQUARE_NUT (flats facing +x), L_BRACKET, BOLT (its long axis) or RECTANGLE (the
    rectangle's long side)."""
    if code == HEX_NUT:
        yaw = _nut_angle(p, 6, 1.0, cut) - math.pi / 6
    elif code == SQUARE_NUT:
        yaw = _nut_angle(p, 4, 2.0, cut)
    elif code == L_BRACKET:
        yaw = _bracket_yaw(p, cx, cy, rect_angle)
    elif code == BOLT:
        yaw = second_moment_angle(p)
    else:
        yaw = rect_angle
    return yaw % (2 * math.pi / n)


@njit(cache=True)
def second_moment_angle(p):  # pragma: no cover (compiled)
    """Direction (rad) of the principal axis of the polygon ``p`` (N, 2, metres):
    0.5 * atan2(2 mu11, mu20 - mu02) of its moments, computed as ``cv2.moments`` does
    for a float32 contour (OpenCV's ``contourMoments`` and ``completeMomentState``, Green's
    theorem) on the outline in millimetres around its first point, rounded to float32."""
    n = p.shape[0]
    x0, y0 = p[0, 0], p[0, 1]
    a00 = a10 = a01 = a20 = a11 = a02 = 0.0
    xi_1 = np.float64(np.float32((p[n - 1, 0] - x0) * 1e3))
    yi_1 = np.float64(np.float32((p[n - 1, 1] - y0) * 1e3))
    for i in range(n):
        xi = np.float64(np.float32((p[i, 0] - x0) * 1e3))
        yi = np.float64(np.float32((p[i, 1] - y0) * 1e3))
        dxy = xi_1 * yi - xi * yi_1
        xii_1 = xi_1 + xi
        yii_1 = yi_1 + yi
        a00 += dxy
        a10 += dxy * xii_1
        a01 += dxy * yii_1
        a20 += dxy * (xi_1 * xii_1 + xi * xi)
        a11 += dxy * (xi_1 * (yii_1 + yi_1) + xi * (yii_1 + yi))
        a02 += dxy * (yi_1 * yii_1 + yi * yi)
        xi_1, yi_1 = xi, yi
    m00 = m10 = m01 = m20 = m11 = m02 = 0.0
    if abs(a00) > 1.1920928955078125e-07:  # FLT_EPSILON
        sign = 1.0 if a00 > 0 else -1.0
        m00, m10, m01 = a00 * (sign * 0.5), a10 * (sign * (1 / 6)), a01 * (sign * (1 / 6))
        m20, m11, m02 = a20 * (sign * (1 / 12)), a11 * (sign * (1 / 24)), a02 * (sign * (1 / 12))
    cx = cy = 0.0
    if abs(m00) > 2.220446049250313e-16:  # DBL_EPSILON
        inv = 1.0 / m00
        cx, cy = m10 * inv, m01 * inv
    mu20, mu11, mu02 = m20 - m10 * cx, m11 - m10 * cy, m02 - m01 * cy
    return 0.5 * math.atan2(2 * mu11, mu20 - mu02)


@njit(cache=True)
def bolt_point(p, cx, cy, rect_angle):  # pragma: no cover (compiled)
    """(x, y) of a bolt's reference point: on its axis, 1.4 mm from the middle of its two
    ends towards the head (see :func:`cell.vision._footprint.bolt_origin`)."""
    ax, ay = math.cos(rect_angle), math.sin(rect_angle)
    m = p.shape[0]
    s = np.empty(m)
    t = np.empty(m)
    for k in range(m):
        s[k] = _along(p, k, cx, cy, ax, ay)
        t[k] = abs(_along(p, k, cx, cy, -ay, ax))
    s_max, s_min = s.max(), s.min()
    w_max = w_min = -np.inf
    for k in range(m):
        if s[k] > s_max - 0.004:
            w_max = max(w_max, t[k])
        if s[k] < s_min + 0.004:
            w_min = max(w_min, t[k])
    to_head = 1.0 if w_max > w_min else -1.0
    mid = 0.5 * (s_max + s_min) + to_head * _BOLT_END_OFFSET
    return cx + mid * ax, cy + mid * ay



@njit(cache=True)
def detection_poses(pts, starts, rows, yaw, xy):  # pragma: no cover (compiled)
    """Yaw and position of each of D detections in one call: outline d is
    ``pts[starts[d]:starts[d + 1]]`` (float64, C-contiguous), ``rows`` (D, 7 or more)
    float64 its centroid x, y, rectangle angle, kind code (:func:`kind_yaw`; < 0: no yaw),
    symmetry order n (0: continuous, yaw 0), cut and whether its position is the bolt's
    reference point (1) or the centroid (0); further columns are not read. Fills ``yaw``
    (D,) and ``xy`` (D, 2)."""
    for d in range(rows.shape[0]):
        p = pts[starts[d] : starts[d + 1]]
        cx, cy, angle = rows[d, 0], rows[d, 1], rows[d, 2]
        code, n, cut = np.int64(rows[d, 3]), np.int64(rows[d, 4]), np.int64(rows[d, 5])
        yaw[d] = kind_yaw(p, cx, cy, angle, code, n, cut) if code >= 0 and n != 0 else 0.0
        if rows[d, 6] != 0:
            xy[d, 0], xy[d, 1] = bolt_point(p, cx, cy, angle)
        else:
            xy[d, 0], xy[d, 1] = cx, cy
