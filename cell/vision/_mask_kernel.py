"""Compiled 0/1 mask operations of the refinement (:mod:`cell.vision._mosaic`), on a
window's masks laid out flat with a one-pixel frame (rows of w + 2): thresholds, and the
3x3 ``cv2.erode``/``cv2.dilate``/``cv2.MORPH_OPEN`` with what lies beyond the window
counting for neither (OpenCV's default border), each a few long loops over the whole
window rather than one per row.
"""

from __future__ import annotations

from numba import njit

__all__: list[str] = []  # private to cell.vision


@njit(cache=True)
def frame(m, h, w, value):  # pragma: no cover (compiled)
    """Set the one-pixel frame around the (h, w) window of padded mask ``m``."""
    for x in range(w + 2):
        m[0, x] = value
        m[h + 1, x] = value
    for y in range(h + 2):
        m[y, 0] = value
        m[y, w + 1] = value


@njit(cache=True)
def above(d, level, out):  # pragma: no cover (compiled)
    """``out`` = ``d`` > ``level``, over whole flat arrays."""
    for e in range(d.shape[0]):
        out[e] = d[e] > level


@njit(cache=True)
def and_above(d, level, out):  # pragma: no cover (compiled)
    """``out`` &= ``d`` > ``level``, over whole flat arrays."""
    for e in range(d.shape[0]):
        out[e] = out[e] & (d[e] > level)


@njit(cache=True)
def min3(src, dst, tmp, wide):  # pragma: no cover (compiled)
    """``dst``: the minimum of 0/1 ``src`` over each pixel's 3x3 neighbourhood, on the
    rows of ``wide`` pixels of flat arrays, at every pixel not on the first or last row
    or column (what those get is not a minimum); ``tmp`` scratch."""
    n = src.shape[0]
    s0, s1, s2, t = src[: n - 2], src[1 : n - 1], src[2:], tmp[1 : n - 1]
    for e in range(n - 2):  # along the rows (across their ends too: unused)
        t[e] = min(min(s0[e], s1[e]), s2[e])
    m = n - 2 * wide
    t0, t1, t2, out = tmp[:m], tmp[wide : wide + m], tmp[2 * wide :], dst[wide : wide + m]
    for e in range(m):
        out[e] = min(min(t0[e], t1[e]), t2[e])


@njit(cache=True)
def max3(src, dst, tmp, wide):  # pragma: no cover (compiled)
    """As :func:`min3`, the maximum."""
    n = src.shape[0]
    s0, s1, s2, t = src[: n - 2], src[1 : n - 1], src[2:], tmp[1 : n - 1]
    for e in range(n - 2):
        t[e] = max(max(s0[e], s1[e]), s2[e])
    m = n - 2 * wide
    t0, t1, t2, out = tmp[:m], tmp[wide : wide + m], tmp[2 * wide :], dst[wide : wide + m]
    for e in range(m):
        out[e] = max(max(t0[e], t1[e]), t2[e])


@njit(cache=True)
def open3(m, work, tmp, h, w):  # pragma: no cover (compiled)
    """3x3 opening of the (h, w) window of 0/1 mask ``m`` (flat, rows of w + 2 with a
    one-pixel frame), in place; what lies beyond the window counts for neither erosion
    nor dilation. The frame of ``m`` is left undefined."""
    wide = w + 2
    frame(m.reshape((h + 2, wide)), h, w, 1)
    min3(m, work, tmp, wide)
    frame(work.reshape((h + 2, wide)), h, w, 0)
    max3(work, m, tmp, wide)
