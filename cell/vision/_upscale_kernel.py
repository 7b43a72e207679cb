"""The background of one frame window for the refinement (:mod:`cell.vision._mosaic`),
compiled: what ``cv2.resize`` (``INTER_LINEAR``, uint8) of the whole 1/8-scale
background by 8 gives there, bit for bit, in 16-bit integers.

OpenCV's weights at scale 8 are multiples of 128 in 1/2048
(:func:`~cell.vision._segment_kernel.upscale_axis`), so they are whole sixteenths
``alpha`` = weight / 128: a row interpolated along x is u = s0 alpha0 + s1 alpha1
(at most 16 x 255, OpenCV's value x 2048 shifted right by 7, exact), and its vector
path's high half of the 16-bit product (8 u) b >> 16 of two such rows with row weight
b = 128 beta is (u beta) >> 6, at most 65280: every step fits 16 bits, so the loops run
16 values to a vector.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__: list[str] = []  # private to cell.vision

_U = np.uint64  # (unsigned indices: no negative-index checks, so the loops vectorise)


@njit(cache=True)
def window_background(bg_small, rows, cols, x0, y0, h, w, inter, at, weights, bg
                      ):  # pragma: no cover (compiled)
    """``bg`` (h, 3 w) uint8: the full-scale background of window (x0, y0, h, w) from
    ``bg_small`` (hs, ws, 3) uint8 and the tables ``rows`` (4, H), ``cols`` (4, W) of
    :func:`~cell.vision._segment_kernel.upscale_axis`; scratch ``inter`` (>= rows
    spanned, >= 3 w) uint16, ``at`` (2, >= w) uint64, ``weights`` (2, >= w) uint16."""
    for x in range(w):  # the window's columns: byte offsets and sixteenths
        at[0, x], at[1, x] = 3 * cols[0, x0 + x], 3 * cols[1, x0 + x]
        weights[0, x], weights[1, x] = cols[2, x0 + x] >> 7, cols[3, x0 + x] >> 7
    small = bg_small.reshape(bg_small.shape[0], 3 * bg_small.shape[1])
    lo = rows[0, y0]
    for i in range(lo, rows[1, y0 + h - 1] + 1):
        _along_x(small[i], at[0, :w], at[1, :w], weights[0, :w], weights[1, :w],
                 inter[i - lo, : 3 * w])
    for y in range(h):
        _lerp(inter[rows[0, y0 + y] - lo], inter[rows[1, y0 + y] - lo],
              rows[2, y0 + y] >> 7, rows[3, y0 + y] >> 7, bg[y, : 3 * w])


@njit(cache=True)
def _along_x(row, at0, at1, a0, a1, out):  # pragma: no cover (compiled)
    """``out`` (3 n,) uint16: RGB row ``row`` (3 ws,) interpolated at n columns, from
    byte offsets ``at0``, ``at1`` and sixteenths ``a0``, ``a1`` (n,)."""
    for x in range(at0.shape[0]):
        u = _U(x)
        b0, b1, w0, w1, e = at0[u], at1[u], a0[u], a1[u], _U(3) * u
        for c in range(3):
            cc = _U(c)
            out[e + cc] = np.uint16(row[b0 + cc]) * w0 + np.uint16(row[b1 + cc]) * w1


@njit(cache=True)
def _lerp(u0, u1, beta0, beta1, out):  # pragma: no cover (compiled)
    """``out`` (n,) uint8: rows ``u0``, ``u1`` (n,) uint16 from :func:`_along_x`
    combined with row weights ``beta0``, ``beta1`` (sixteenths) as ``cv2.resize``'s
    vector path rounds them: ((u0 beta0) >> 6 + (u1 beta1) >> 6 + 2) >> 2, saturated."""
    b0, b1 = np.uint16(beta0), np.uint16(beta1)
    two, top = np.uint16(2), np.uint16(255)
    for e in range(out.shape[0]):
        s = (np.uint16(u0[e] * b0) >> np.uint16(6)) + (np.uint16(u1[e] * b1) >> np.uint16(6))
        out[e] = min(np.uint16(np.uint16(s + two) >> np.uint16(2)), top)
