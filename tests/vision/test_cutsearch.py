"""The split stage's compiled cut generation against what it replaces: CPython's
``math.hypot``, ``cv2.pointPolygonTest``, ``np.round``, ``cv2.convexHull``,
``cv2.convexityDefects``, and
the cuts the Python search made from them (pairs, order, sampled points, normals, rays)."""

from __future__ import annotations

import math

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.vision._blobwindows import blobs_of_mask
from cell.vision._cutsearch import cut_candidates, int_outline, point_in_polygon, py_hypot
from cell.vision._hull import convex_hull, convexity_defects
from cell.vision._polygons import plane_rays
from tests.vision.test_split import _camera


def test_hypot_is_cpythons_to_the_last_bit():
    rng = np.random.default_rng(1)
    a = rng.integers(-80, 80, 20000) + rng.uniform(-0.7, 0.7, 20000)
    b = rng.integers(-80, 80, 20000) + rng.uniform(-0.7, 0.7, 20000) * (rng.random(20000) < 0.5)
    a[:4], b[:4] = (0.0, 3.0, 1e-310, -2.0), (0.0, 4.0, 3e-310, 0.0)
    for x, y in zip(a.tolist(), b.tolist(), strict=True):
        assert py_hypot(x, y) == math.hypot(x, y)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 30), st.integers(0, 30)), min_size=3, max_size=25),
       st.integers(-2, 63), st.integers(-2, 63))
def test_point_in_polygon_matches_opencv(pts, hx, hy):
    poly = np.array(pts, np.int32)
    px, py = hx / 2.0, hy / 2.0  # the half-pixel grid of the cuts' midpoints
    assert point_in_polygon(poly, px, py) == cv2.pointPolygonTest(poly, (px, py), False)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31))
def test_int_outline_rounds_as_numpy(seed):
    rng = np.random.default_rng(seed)
    c = rng.integers(0, 400, (50, 2)) + rng.choice([0.0, 0.5, 0.25, -0.5], (50, 2))
    nr = rng.choice([0.0, 1.0, -1.0, 0.6], (50, 2))
    np.testing.assert_array_equal(int_outline(c, nr), np.round(c - 0.5 * nr).astype(np.int32))


def _python_cuts(c, nr, outline, defects):
    """The cuts as the split stage made them in Python (before they were compiled)."""
    deep = sorted(((fi, di) for _, _, fi, di in defects.tolist() if di >= 2.5 * 256),
                  key=lambda r: -r[1])[:6]
    pts = outline.tolist()
    pairs = []
    for i in range(len(deep)):
        for j in range(i + 1, len(deep)):
            (fi, di), (fj, dj) = deep[i], deep[j]
            pairs.append((math.dist(pts[fi], pts[fj]) / ((di + dj) / 256.0), min(fi, fj),
                          max(fi, fj)))
    pairs.sort()
    n = len(outline)
    side = 1.0 if (c[1, 0] - c[0, 0]) * nr[0, 1] - (c[1, 1] - c[0, 1]) * nr[0, 0] > 0 else -1.0
    for _, fi, fj in pairs[:6]:
        if fj - fi < 8 or n - (fj - fi) < 8:
            continue
        mid = ((pts[fi][0] + pts[fj][0]) / 2.0, (pts[fi][1] + pts[fj][1]) / 2.0)
        if cv2.pointPolygonTest(outline, mid, False) < 0:
            continue
        (ax, ay), (bx, by) = c[fj].tolist(), c[fi].tolist()
        length = max(math.hypot(bx - ax, by - ay), 1e-9)
        steps = max(int(length), 1)
        t = np.arange(1.0, steps) / steps
        cut = np.stack((ax + t * (bx - ax), ay + t * (by - ay)), axis=1)
        out = np.empty_like(cut)
        out[:, 0] = -side * (by - ay) / length
        out[:, 1] = side * (bx - ax) / length
        yield fi, fj, cut, out


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31))
def test_cuts_are_those_the_python_search_made(seed):
    """Blobs of a few random overlapping discs and boxes: the same cuts, bit for bit."""
    rng = np.random.default_rng(seed)
    mask = np.zeros((200, 260), np.uint8)
    for _ in range(rng.integers(2, 5)):
        x, y = (int(v) for v in rng.integers(60, 180, 2))
        if rng.random() < 0.5:
            cv2.circle(mask, (x, y), int(rng.integers(12, 40)), 255, -1)
        else:
            box = ((x, y), tuple(float(v) for v in rng.integers(15, 70, 2)), float(rng.uniform(0, 180)))
            cv2.fillPoly(mask, [cv2.boxPoints(box).astype(np.int32)], 255)
    cam = _camera()
    K, R = cam.K, cam.T_world_camera[:3, :3]
    for blob in blobs_of_mask(mask, (3, 5)):
        outline = int_outline(blob.contour, blob.normals)
        hull = cv2.convexHull(outline, returnPoints=False)
        try:
            defects = cv2.convexityDefects(outline, hull)
        except cv2.error:
            continue
        if defects is None:
            continue
        defects = defects.reshape(-1, 4)
        first, second, starts, cut, out, rays, away = cut_candidates(
            blob.contour, blob.normals, outline, hull.reshape(-1), True, K[0, 0], K[1, 1], K[0, 2],
            K[1, 2], K[0, 1], np.ascontiguousarray(R), 300.0, 250.0, True)
        expect = list(_python_cuts(blob.contour, blob.normals, outline, defects))
        assert len(expect) == len(first)
        for k, (fi, fj, ecut, eout) in enumerate(expect):
            assert (first[k], second[k]) == (fi, fj)
            s, e = starts[k], starts[k + 1]
            np.testing.assert_array_equal(cut[s:e], ecut)
            np.testing.assert_array_equal(out[s:e], eout)
            erays, eaway = plane_rays(ecut, eout, None, K, R, np.array([300.0, 250.0]))
            np.testing.assert_allclose(rays[s:e], erays, rtol=1e-9, atol=1e-12)
            np.testing.assert_array_equal(away[s:e], eaway)


def _scribble(rng: np.random.Generator) -> np.ndarray:
    """A mask of random discs, boxes and thin lines (thin parts make self-touching
    outlines, whose hull OpenCV finds not monotonous)."""
    mask = np.zeros((120, 160), np.uint8)
    for _ in range(rng.integers(1, 6)):
        x, y = (int(v) for v in rng.integers(10, 110, 2))
        pick = rng.random()
        if pick < 0.4:
            cv2.circle(mask, (x, y), int(rng.integers(3, 30)), 255, -1)
        elif pick < 0.7:
            end = (int(rng.integers(0, 160)), int(rng.integers(0, 120)))
            cv2.line(mask, (x, y), end, 255, int(rng.integers(1, 4)))
        else:
            box = ((x, y), tuple(float(v) for v in rng.integers(2, 50, 2)), float(rng.uniform(0, 180)))
            cv2.fillPoly(mask, [cv2.boxPoints(box).astype(np.int32)], 255)
    return mask


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**31))
def test_convexity_defects_match_opencv(seed):
    """Same rows in the same order, and False exactly where OpenCV raises."""
    for blob in blobs_of_mask(_scribble(np.random.default_rng(seed)), (0, 0)):
        outline = int_outline(blob.contour, blob.normals)
        hull = cv2.convexHull(outline, returnPoints=False)
        try:
            expect, ok = cv2.convexityDefects(outline, hull), True
        except cv2.error:
            expect, ok = None, False
        got, got_ok = convexity_defects(outline, hull.reshape(-1))
        assert got_ok == ok
        if ok:
            np.testing.assert_array_equal(
                got, np.zeros((0, 4)) if expect is None else expect.reshape(-1, 4))


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**31))
def test_plain_convex_hulls_match_opencv(seed):
    """Where the compiled hull answers (not empty), it is OpenCV's, index for index, for
    contours as traced, reversed and starting anywhere."""
    rng = np.random.default_rng(seed)
    for blob in blobs_of_mask(_scribble(rng), (0, 0)):
        outline = int_outline(blob.contour, blob.normals)
        turn = int(rng.integers(len(outline)))
        for pts in (outline, outline[::-1].copy(), np.roll(outline, turn, axis=0).copy()):
            got = convex_hull(pts)
            if len(got):
                np.testing.assert_array_equal(
                    got, cv2.convexHull(pts, returnPoints=False).reshape(-1))
