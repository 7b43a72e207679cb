"""Contours filled as ``cv2.drawContours(image, contours, -1, value, cv2.FILLED)`` fills
them, for pixel chains (``cv2.findContours`` with ``CHAIN_APPROX_NONE``: each point
8-adjacent to the next, the last to the first), in one compiled call (numba).

OpenCV fills the polygons as ``fillPoly`` does (imgproc/src/drawing.cpp, CollectPolyEdges
and FillEdgeCollection): each edge drawn as an 8-connected line, and a scan-line fill of
all the polygons' edges at once, in which each non-horizontal edge covers the rows from
its upper end to the row above its lower end, its x starting at its upper end; on each
row the sorted crossings are paired and each pair filled from the first to the second.
An edge of a chain spans one row, so: every point is set, and on each row the upper ends
of the edges that leave it downwards or arrive from below, sorted, pair up into spans.
Contours lying apart in x (the windows of a mosaic) pair up each on its own, as they do
in OpenCV's one fill of all of them. ``tests/vision/test_fillchain.py`` checks it
against ``cv2.drawContours`` pixel for pixel.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__: list[str] = []  # private to cell.vision


@njit(cache=True)
def fill_chains(out, pts, starts, shifts, value):  # pragma: no cover (compiled)
    """Fill (``value``) in ``out`` (H, W) uint8 each chain ``pts[starts[b]:starts[b +
    1]]`` (int32 (x, y)) moved by ``shifts[b]`` (dx, dy), all inside ``out``."""
    w = out.shape[1]
    keys = np.empty(0, np.int64)
    for b in range(starts.shape[0] - 1):
        s, e = starts[b], starts[b + 1]
        dx, dy = shifts[b, 0], shifts[b, 1]
        if keys.shape[0] < e - s:
            keys = np.empty(2 * (e - s), np.int64)
        m = 0
        xj, yj = pts[e - 1, 0] + dx, pts[e - 1, 1] + dy
        for k in range(s, e):
            x, y = pts[k, 0] + dx, pts[k, 1] + dy
            out[y, x] = value
            if yj != y:  # an edge's crossing: its upper end
                keys[m] = yj * w + xj if yj < y else y * w + x
                m += 1
            xj, yj = x, y
        crossings = np.sort(keys[:m])
        for a in range(0, m - 1, 2):
            row = crossings[a] // w
            for x in range(crossings[a] - row * w, crossings[a + 1] - row * w + 1):
                out[row, x] = value
