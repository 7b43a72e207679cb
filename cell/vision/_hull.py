"""The convex hull of an integer contour and its convexity defects, as OpenCV gives them
(``cv2.convexHull(..., returnPoints=False)``, ``cv2.convexityDefects``; imgproc/src/
convhull.cpp), compiled (numba) for the split stage (:mod:`cell.vision._cutsearch`).

The hull is Andrew's monotone chain (*Information Processing Letters* 9, 1979) put in
OpenCV's vertex order; where OpenCV's own choices could differ (a hull vertex the
contour passes twice, hull indices not monotonous) it answers nothing and the caller
asks OpenCV. ``tests/vision/test_cutsearch.py`` checks both against OpenCV.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__: list[str] = []  # private to cell.vision


@njit(cache=True)
def _cross(points, o, a, b):  # pragma: no cover (compiled)
    """z of (a - o) x (b - o) for points o, a, b (indices; exact on integers)."""
    return ((points[a, 0] - points[o, 0]) * (points[b, 1] - points[o, 1])
            - (points[a, 1] - points[o, 1]) * (points[b, 0] - points[o, 0]))


@njit(cache=True)
def convex_hull(points):  # pragma: no cover (compiled)
    """``cv2.convexHull(points, returnPoints=False)`` (flattened) of an integer contour
    whose hull is plain: its vertices (Andrew's monotone chain, *Information Processing
    Letters* 9, 1979; no collinear vertices, as OpenCV's Sklansky scan keeps none) in
    OpenCV's order (positive shoelace area, starting at the lowest index when the
    indices then ascend, at the highest when they descend). Empty where the hull is not
    plain (a vertex the contour passes twice, indices not monotonous, fewer than three
    vertices): OpenCV's choices there are left to OpenCV."""
    n = points.shape[0]
    empty = np.empty(0, np.int32)
    if n < 3:
        return empty
    # only the lowest and highest point of each column can be a vertex (any other lies
    # between them): those, in the (x, y) order the chain takes, with how often each
    # point occurs (a vertex the contour passes twice is OpenCV's choice)
    x0, x1 = points[0, 0], points[0, 0]
    for i in range(1, n):
        x0, x1 = min(x0, points[i, 0]), max(x1, points[i, 0])
    w = np.int64(x1) - np.int64(x0) + 1
    lo_i = np.full(w, -1, np.int64)
    hi_i = np.full(w, -1, np.int64)
    lo_n = np.zeros(w, np.int64)
    hi_n = np.zeros(w, np.int64)
    for i in range(n):
        c = np.int64(points[i, 0]) - np.int64(x0)
        y = points[i, 1]
        if lo_i[c] < 0:
            lo_i[c], hi_i[c], lo_n[c], hi_n[c] = i, i, 1, 1
            continue
        ly, hy = points[lo_i[c], 1], points[hi_i[c], 1]
        if y < ly:
            lo_i[c], lo_n[c] = i, 1
        elif y == ly:
            lo_n[c] += 1
        if y > hy:
            hi_i[c], hi_n[c] = i, 1
        elif y == hy:
            hi_n[c] += 1
    order = np.empty(2 * w, np.int64)
    twice = np.zeros(n, np.bool_)
    n_ord = 0
    for c in range(w):
        if lo_i[c] < 0:
            continue
        order[n_ord] = lo_i[c]
        twice[lo_i[c]] = lo_n[c] > 1
        n_ord += 1
        if hi_i[c] != lo_i[c] and points[hi_i[c], 1] != points[lo_i[c], 1]:
            order[n_ord] = hi_i[c]
            twice[hi_i[c]] = hi_n[c] > 1
            n_ord += 1
    h = np.empty(2 * n_ord + 1, np.int64)
    k = 0
    for q in range(n_ord):  # lower hull, then upper: counter-clockwise in (x, y)
        i = order[q]
        while k >= 2 and _cross(points, h[k - 2], h[k - 1], i) <= 0:
            k -= 1
        h[k] = i
        k += 1
    low = k + 1
    for q in range(n_ord - 2, -1, -1):
        i = order[q]
        while k >= low and _cross(points, h[k - 2], h[k - 1], i) <= 0:
            k -= 1
        h[k] = i
        k += 1
    m = k - 1
    if m < 3:
        return empty
    for v in range(m):  # a vertex the contour passes twice: which index OpenCV takes varies
        if twice[h[v]]:
            return empty
    lo = hi = 0
    for v in range(1, m):
        if h[v] < h[lo]:
            lo = v
        if h[v] > h[hi]:
            hi = v
    up = down = True
    for v in range(1, m):
        up = up and h[(lo + v) % m] > h[(lo + v - 1) % m]
        down = down and h[(hi + v) % m] < h[(hi + v - 1) % m]
    if not (up or down):
        return empty
    start = lo if up else hi
    out = np.empty(m, np.int32)
    for v in range(m):
        out[v] = h[(start + v) % m]
    return out


@njit(cache=True)
def convexity_defects(points, hull):  # pragma: no cover (compiled)
    """``cv2.convexityDefects(points, hull)`` (imgproc/src/convhull.cpp) of an integer
    contour ``points`` (N, 2) and its hull indices (``cv2.convexHull(...,
    returnPoints=False)``, flattened): rows (start, end, farthest point, depth in 1/256
    px, rounded half to even as ``cvRound``), one per hull edge with points off it, and
    False where OpenCV raises (hull indices not monotonous: a self-touching contour)."""
    n, h = points.shape[0], hull.shape[0]
    out = np.empty((h, 4), np.int64)
    if n <= 3 or h < 3:
        return out[:0], True
    rev = ((hull[1] > hull[0]) + (hull[2] > hull[1]) + (hull[0] > hull[2])) != 2
    hcurr = hull[0] if rev else hull[h - 1]
    increasing = -1
    k = 0
    for i in range(h):
        hnext = hull[h - i - 1] if rev else hull[i]
        if increasing < 0:
            increasing = 0 if hcurr < hnext else 1
        elif increasing != (1 if hcurr < hnext else 0):
            return out[:0], False
        x0, y0 = float(points[hcurr, 0]), float(points[hcurr, 1])
        dx0, dy0 = float(points[hnext, 0]) - x0, float(points[hnext, 1]) - y0
        scale = 0.0 if dx0 == 0 and dy0 == 0 else 1.0 / math.sqrt(dx0 * dx0 + dy0 * dy0)
        deepest, depth = -1, 0.0
        j = hcurr
        while True:
            j = j + 1 if j + 1 < n else 0
            if j == hnext:
                break
            dx, dy = float(points[j, 0]) - x0, float(points[j, 1]) - y0
            dist = abs(-dy0 * dx + dx0 * dy) * scale
            if dist > depth:
                depth, deepest = dist, j
        if deepest >= 0:
            out[k, 0], out[k, 1], out[k, 2] = hcurr, hnext, deepest
            out[k, 3] = np.int64(np.rint(depth * 256))
            k += 1
        hcurr = hnext
    return out[:k], True
