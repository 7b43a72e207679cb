"""The tree of the border following of :mod:`cell.vision._contours` (compiled, numba):
which border a hole border lies in, and the borders in OpenCV's output order
(imgproc/src/contours_new.cpp: ``findFirstBoundingContour``, ``icvTraceContour`` and
``contourTreeToResults``).

Each border found is a row of ``node`` (n, 11) int64: parent, first child, previous and
next sibling, the next border of the same label (-1: none), whether a hole, its first
pixel (flat index of the framed image) and the rectangle x, y, w, h (framed coordinates)
that OpenCV keeps of it; row 0 is the root, a hole framing the image.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__: list[str] = []  # private to cell.vision


@njit(cache=True)
def bounding(img, node, cur, last_x, y, stride, delta):  # pragma: no cover (compiled)
    """The border a hole starting on row ``y`` lies in, among those of the label met last
    on that row (at ``last_x``; ``cur`` the newest of them, the older ones by ``node``'s
    label links): the newest whose rectangle holds the point, passed over for the next
    older such one as long as following it again does not end at the point (OpenCV's
    findFirstBoundingContour; it matters only once labels repeat, past 126 borders)."""
    res = -1
    end = y * stride + last_x
    while cur != -1:
        if last_x - node[cur, 7] < node[cur, 9] and y - node[cur, 8] < node[cur, 10]:
            if res != -1 and _reaches(img, node[res, 6], end, node[res, 5] == 1, delta):
                break
            res = cur
        cur = node[cur, 4]
    return res


@njit(cache=True)
def first_step(img, i0, is_hole, delta):  # pragma: no cover (compiled)
    """(s, i1): the first nonzero neighbour of flat index ``i0`` clockwise from the
    border's start direction (0 for a hole, 4 for an outer border), as OpenCV's
    border following looks for it; s is that start direction itself (and i1 its
    neighbour) when there is none: a single pixel."""
    s_end = 0 if is_hole else 4
    s = s_end
    while True:
        s = (s - 1) & 7
        i1 = i0 + delta[s]
        if img[i1] != 0 or s == s_end:
            return s, i1


@njit(cache=True)
def next_step(img, i3, s, delta):  # pragma: no cover (compiled)
    """(s, i4): the next nonzero neighbour of flat index ``i3`` counter-clockwise after
    direction ``s`` (``delta`` holds the eight steps twice, so s runs up to 15 without
    wrapping); s is not reduced mod 8."""
    i4 = i3
    while s < 15:
        s += 1
        i4 = i3 + delta[s]
        if img[i4] != 0:
            break
    return s, i4


@njit(cache=True)
def _reaches(img, i0, stop, is_hole, delta):  # pragma: no cover (compiled)
    """Whether following (without labelling) the border from flat index ``i0`` ends at
    ``stop`` as the last border of its label met on that row (OpenCV's
    icvTraceContour)."""
    s, i1 = first_step(img, i0, is_hole, delta)
    i3 = i0
    if s == (0 if is_hole else 4):
        return i3 == stop
    while True:
        s, i4 = next_step(img, i3, s, delta)
        if i3 == stop:
            if img[i3] & 128 == 0:
                return True
            t = s
            while True:
                t = (t - 1) & 7
                if img[i3 + delta[t]] != 0:
                    break
                if t == 0:
                    return True
        if i4 == i0 and i3 == i1:
            break
        i3 = i4
        s = (s + 4) & 7
    return False


@njit(cache=True)
def results(node, span, pts, n):  # pragma: no cover (compiled)
    """The contours 1..n-1 of the tree ``node`` in OpenCV's output order (depth first
    from the root, each node's newest child first) with their hierarchy rows."""
    order = np.empty(n - 1, np.int64)
    index = np.full(n, -1, np.int64)  # (the root maps to -1)
    stack = np.empty(n, np.int64)
    stack[0] = 0
    top, k = 1, 0
    total = 0
    while top:
        top -= 1
        i = stack[top]
        if i != 0:
            order[k], index[i] = i, k
            k += 1
            total += span[i, 1] - span[i, 0]
        c = node[i, 1]  # push the children oldest first, so the newest comes out first
        last = -1
        while c != -1:
            last = c
            c = node[c, 3]
        c = last
        while c != -1:
            stack[top] = c
            top += 1
            c = node[c, 2]
    out = np.empty((total, 2), np.int32)
    starts = np.zeros(n, np.int64)
    hier = np.empty((n - 1, 4), np.int32)
    for k in range(n - 1):
        i = order[k]
        a, b = span[i, 0], span[i, 1]
        out[starts[k] : starts[k] + b - a] = pts[a:b]
        starts[k + 1] = starts[k] + b - a
        for j, f in enumerate((3, 2, 1, 0)):
            hier[k, j] = index[node[i, f]] if node[i, f] != -1 else -1
    return out, starts, hier
