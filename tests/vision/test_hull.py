"""The compiled convex hull (bucket sort + Andrew's monotone chain) against the textbook
algorithm on ``np.argsort``'s order, and against ``cv2.convexHull``."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.vision._polygons import _by_x, _hull


def _andrew(px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Andrew's monotone chain on the points ordered by ``np.argsort`` of the same key."""
    order = np.argsort(px + 1e-9 * py, kind="stable")
    h: list[int] = []

    def turn(a: int, b: int, i: int) -> float:
        return ((px[b] - px[a]) * (py[i] - py[a])) - ((py[b] - py[a]) * (px[i] - px[a]))

    for i in order:
        while len(h) >= 2 and turn(h[-2], h[-1], i) <= 0:
            h.pop()
        h.append(i)
    lower = len(h) + 1
    for i in order[-2::-1]:
        while len(h) >= lower and turn(h[-2], h[-1], i) <= 0:
            h.pop()
        h.append(i)
    h = h[: max(len(h) - 1, 1)]
    return px[h], py[h]


coords = st.floats(-60.0, 60.0, allow_nan=False, allow_subnormal=False)
grid = st.integers(-12, 12).map(float)  # many ties and collinear points
points = st.one_of(
    st.lists(st.tuples(coords, coords), min_size=1, max_size=300),
    st.lists(st.tuples(grid, grid), min_size=1, max_size=120),
)


@settings(max_examples=300, deadline=None)
@given(points)
def test_bucket_order_is_argsort_order(pts):
    p = np.array(pts)
    key = p[:, 0] + 1e-9 * p[:, 1]
    order = _by_x(p[:, 0].copy(), p[:, 1].copy())
    assert sorted(order.tolist()) == list(range(len(p)))
    np.testing.assert_array_equal(key[order], np.sort(key))


@settings(max_examples=300, deadline=None)
@given(points)
def test_hull_is_andrews_monotone_chain(pts):
    p = np.array(pts)
    hx, hy = _hull(p[:, 0].copy(), p[:, 1].copy())
    rx, ry = _andrew(p[:, 0], p[:, 1])
    np.testing.assert_array_equal(hx, rx)
    np.testing.assert_array_equal(hy, ry)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(grid, grid), min_size=3, max_size=120, unique=True))
def test_hull_vertices_are_opencvs(pts):
    p = np.array(pts)
    hx, hy = _hull(p[:, 0].copy(), p[:, 1].copy())
    ref = cv2.convexHull(p.astype(np.float32), clockwise=False).reshape(-1, 2)
    if cv2.contourArea(ref) == 0:  # all on a line: OpenCV keeps its two ends, so do we
        assert {tuple(q) for q in np.stack([hx, hy], 1)} <= {tuple(q) for q in p}
        return
    ours = [(float(x), float(y)) for x, y in zip(hx, hy, strict=True)]
    theirs = [(float(x), float(y)) for x, y in ref]
    assert sorted(ours) == sorted(theirs)
    start = theirs.index(ours[0])  # the same cycle, counter-clockwise
    assert theirs[start:] + theirs[:start] == ours
