"""A split piece's own pixels: its outline filled as ``cv2.fillPoly`` fills it, within its
parent's mask, in one compiled call (numba).

The split stage (:mod:`cell.vision._split`) gives each piece of a straight cut the
pixels of its parent's mask that its outline covers: ``cv2.fillPoly`` of the outline's
pixel centres (:func:`cell.vision._cutsearch.int_outline`; integer points, 8-connected
edges, no sub-pixel shift) ANDed with the mask. :func:`fill_within` does both at once
with OpenCV's arithmetic (imgproc/src/drawing.cpp): every edge drawn as an 8-connected
Bresenham line (``LineIterator``, left to right), and the scan-line fill of
``CollectPolyEdges`` / ``FillEdgeCollection`` in 16.16 fixed point: each non-horizontal
edge covers the rows from its upper end to the row above its lower end, its x starting
at its upper end and moving by the truncated quotient of the x and y spans per row; on
each row the sorted crossings are paired and each pair filled from the first's ceiling
to the second's floor. ``tests/vision/test_polyfill.py`` checks it
against ``cv2.fillPoly`` pixel for pixel.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__: list[str] = []  # private to cell.vision

_SHIFT = 16  # OpenCV's XY_SHIFT: the fill's fixed point


@njit(cache=True)
def _line(out, mask, x1, y1, x2, y2):  # pragma: no cover (compiled)
    """``out`` = ``mask`` on the 8-connected line from (x1, y1) to (x2, y2), as
    ``cv2.line`` draws it (``LineIterator``, left to right), both ends inside."""
    dx, dy = x2 - x1, y2 - y1
    if dx < 0:  # left to right
        x1, y1, dx, dy = x2, y2, -dx, -dy
    sy = 1
    if dy < 0:
        dy, sy = -dy, -1
    vert = dy > dx
    if vert:
        dx, dy = dy, dx
    err = dx - 2 * dy
    x, y = x1, y1
    for _ in range(dx + 1):
        out[y, x] = mask[y, x]
        minor = err < 0
        err += -2 * dy + (2 * dx if minor else 0)
        if vert:
            y += sy
            if minor:
                x += 1
        else:
            x += 1
            if minor:
                y += sy


@njit(cache=True)
def _trunc_div(a, b):  # pragma: no cover (compiled)
    """a / b rounded toward zero, as C's integer division."""
    q = abs(a) // abs(b)
    return q if (a < 0) == (b < 0) else -q


@njit(cache=True)
def fill_within(mask, contour, normals, x0, y0):  # pragma: no cover (compiled)
    """(ok, own): ``own`` the pixels of ``mask`` (uint8 (H, W), its pixel (0, 0) at
    frame pixel (x0, y0)) that ``cv2.fillPoly`` of the outline's pixel centres
    (``contour - 0.5 * normals`` rounded half to even, frame pixels) covers, else 0;
    ok False (and ``own`` empty) where a centre lies outside the mask (OpenCV then
    clips: the caller asks it)."""
    h, w = mask.shape
    n = contour.shape[0]
    px = np.empty(n, np.int64)
    py = np.empty(n, np.int64)
    for k in range(n):
        px[k] = np.int64(np.rint(contour[k, 0] - 0.5 * normals[k, 0])) - x0
        py[k] = np.int64(np.rint(contour[k, 1] - 0.5 * normals[k, 1])) - y0
        if px[k] < 0 or px[k] >= w or py[k] < 0 or py[k] >= h:
            return False, np.empty((0, 0), np.uint8)
    own = np.zeros((h, w), np.uint8)
    # the edges (upper row, row below the lower end, fixed-point x at the upper row, step)
    ey0 = np.empty(n, np.int64)
    ey1 = np.empty(n, np.int64)
    ex = np.empty(n, np.int64)
    edx = np.empty(n, np.int64)
    m = 0
    j = n - 1
    for k in range(n):
        _line(own, mask, px[j], py[j], px[k], py[k])
        if py[j] != py[k]:
            xj, xk = px[j] << _SHIFT, px[k] << _SHIFT
            edx[m] = _trunc_div(xk - xj, py[k] - py[j])
            if py[j] < py[k]:
                ey0[m], ey1[m], ex[m] = py[j], py[k], xj
            else:
                ey0[m], ey1[m], ex[m] = py[k], py[j], xk
            m += 1
        j = k
    if m < 2:
        return True, own
    first = np.zeros(h + 1, np.int64)  # the edges by upper row (a counting sort)
    y_end = 0
    for e in range(m):
        first[ey0[e] + 1] += 1
        y_end = max(y_end, ey1[e])
    for y in range(h):
        first[y + 1] += first[y]
    order = np.empty(m, np.int64)
    at = first.copy()
    for e in range(m):
        order[at[ey0[e]]] = e
        at[ey0[e]] += 1
    active = np.empty(m, np.int64)  # edges crossing the row
    xs = np.empty(m, np.int64)
    na = 0
    y = ey0[order[0]]
    while y < y_end:
        k = 0
        for a in range(na):  # drop the edges that ended
            if ey1[active[a]] != y:
                active[k] = active[a]
                k += 1
        na = k
        for q in range(first[y], first[y + 1]):
            active[na] = order[q]
            na += 1
        for a in range(na):  # their crossings, sorted (insertion)
            v = ex[active[a]] + (y - ey0[active[a]]) * edx[active[a]]
            b = a
            while b > 0 and xs[b - 1] > v:
                xs[b] = xs[b - 1]
                b -= 1
            xs[b] = v
        for a in range(0, na - 1, 2):
            x1 = (xs[a] + (1 << _SHIFT) - 1) >> _SHIFT
            x2 = xs[a + 1] >> _SHIFT
            for x in range(max(x1, 0), min(x2, w - 1) + 1):
                own[y, x] = mask[y, x]
        y += 1
    return True, own
