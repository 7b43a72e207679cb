"""Shape descriptors of many footprints (polygons with holes on the table plane) at once.

The detector describes every candidate footprint of a step in one call: the outline and
hole points of all footprints are concatenated with their rays, and one compiled pass
(numba) maps each point onto the plane at its edge height and computes, per footprint:

* net area, outline area and centroid from polygon moments (Green's theorem; the
  quantities ``cv2.moments`` gives for a contour);
* the convex hull of the outline (Andrew's monotone chain, *Information Processing
  Letters* 9, 1979, on the points bucket-sorted by x) and its area;
* the minimum-area enclosing rectangle: one of its sides lies on a hull edge (Freeman &
  Shapira, *CACM* 18, 1975), so every hull edge is tried (the rectangle
  ``cv2.minAreaRect`` finds by rotating calipers);
* the six-fold facet strength: the 6th circular harmonic of the hull's edge directions,
  weighted by length (Mardia & Jupp, *Directional Statistics*, 2000).

Descriptors are computed in millimetres around each footprint's first outline point.
``tests/vision/test_polygons.py`` checks them against OpenCV.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__: list[str] = []  # private to cell.vision

# columns of the descriptor table
_AREA, _OUTER, _CX, _CY, _LENGTH, _WIDTH, _ANGLE, _HOLES, _SOLIDITY, _FACETS = range(10)


@dataclass
class PolygonSet:
    """Descriptors of ``n`` footprints, each an array of length n.

    ``area`` net area (m^2), ``outer`` the outline's area (m^2), ``centroid`` (n, 2) (m),
    ``length``/``width`` the minimum-area rectangle's sides (m, length >= width),
    ``rect_angle`` the long side's direction (rad, in (-pi, pi]), ``hole_fraction``,
    ``solidity`` (outline area over hull area), ``facets6`` (0..1).
    """

    area: np.ndarray
    outer: np.ndarray
    centroid: np.ndarray
    length: np.ndarray
    width: np.ndarray
    rect_angle: np.ndarray
    hole_fraction: np.ndarray
    solidity: np.ndarray
    facets6: np.ndarray
    table: np.ndarray  # (n, 10): the rows these are columns of


def describe_polygons(pts: np.ndarray, starts: np.ndarray, outlines: np.ndarray) -> PolygonSet:
    """Descriptors of footprints whose polygons are concatenated in ``pts``.

    Parameters
    ----------
    pts : (N, 2) float64, every polygon's vertices in order (metres).
    starts : (P + 1,) int, polygon p is ``pts[starts[p]:starts[p + 1]]`` (>= 3 points).
    outlines : (n,) int, footprint i is polygons ``outlines[i]`` (its outer boundary) up
        to ``outlines[i + 1]`` (exclusive; the last up to P): the outline, then its holes.
    """
    table = np.empty((len(outlines), 10))
    _describe(np.ascontiguousarray(pts, dtype=np.float64), np.asarray(starts, np.int64),
              np.asarray(outlines, np.int64), table)
    return as_set(table)


def plane_footprints(rays: np.ndarray, away: np.ndarray, splits: np.ndarray, counts: np.ndarray,
                     lo: np.ndarray, hi: np.ndarray, origin: np.ndarray,
                     drop: float) -> tuple[np.ndarray, np.ndarray, PolygonSet]:
    """Plane points and descriptors of n footprints given by rays (one compiled pass).

    Parameters
    ----------
    rays : (N, 2) world xy travelled per metre of height along each point's ray
        (footprint after footprint; within one, its outline then its holes).
    away : (N,) bool, the point is on an edge facing away from the camera's nadir.
    splits : each footprint's cumulative polygon sizes, concatenated (its outline's
        size, then outline + first hole, ...); ``counts`` (n,) how many polygons each has.
    lo, hi : (n,) heights above the plane (m) of each footprint's edges facing the nadir
        and facing away.
    origin : (2,) the camera's world xy; ``drop`` the plane's height below it (m, < 0).

    Point k lies at ``origin + (drop + h_k) * rays[k]``. Returns (points (N, 2), polygon
    starts (P + 1,), descriptors).
    """
    xy = np.empty((len(rays), 2))
    starts = np.empty(len(splits) + 1, np.int64)
    table = np.empty((len(counts), 10))
    _plane_describe(rays, away, splits, counts, lo, hi, float(origin[0]), float(origin[1]),
                    float(drop), xy, starts, table)
    return xy, starts, as_set(table)


def as_set(t: np.ndarray) -> PolygonSet:
    """The :class:`PolygonSet` view of an (n, 10) descriptor table."""
    return PolygonSet(
        area=t[:, _AREA], outer=t[:, _OUTER], centroid=t[:, _CX : _CY + 1],
        length=t[:, _LENGTH], width=t[:, _WIDTH], rect_angle=t[:, _ANGLE],
        hole_fraction=t[:, _HOLES], solidity=t[:, _SOLIDITY], facets6=t[:, _FACETS], table=t,
    )


@njit(cache=True)
def _plane_describe(rays, away, splits, counts, lo, hi, ox, oy, drop, xy, starts,
                    table):  # pragma: no cover (compiled)
    n = counts.shape[0]
    outlines = np.empty(n, np.int64)
    k = 0  # point index
    p = 0  # polygon index
    starts[0] = 0
    for i in range(n):
        outlines[i] = p
        base = k
        for _ in range(counts[i]):
            end = base + splits[p]
            starts[p + 1] = end
            p += 1
        for q in range(k, end):
            h = hi[i] if away[q] else lo[i]
            xy[q, 0] = ox + (drop + h) * rays[q, 0]
            xy[q, 1] = oy + (drop + h) * rays[q, 1]
        k = end
    _describe(xy, starts, outlines, table)


def plane_rays(uv: np.ndarray, normals: np.ndarray, norm: np.ndarray | None, K: np.ndarray,
               R: np.ndarray, nadir: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(rays (N, 2), away (N,)) of outline points ``uv`` (N, 2, pixels) with outward
    ``normals`` (N, 2): world xy travelled per metre of height along each point's ray,
    and whether the normal points away from the camera's ``nadir`` pixel (a top edge).
    ``norm`` gives the points' normalised (undistorted) image coordinates where the lens
    distorts, else None: the pinhole ``K`` maps them. ``R`` rotates camera to world."""
    rays = np.empty((len(uv), 2))
    away = np.empty(len(uv), np.bool_)
    pinhole = norm is None
    _rays(uv, uv if pinhole else norm, normals, pinhole, float(K[0, 0]), float(K[1, 1]),
          float(K[0, 2]), float(K[1, 2]), float(K[0, 1]), np.ascontiguousarray(R, dtype=np.float64),
          0.0 if nadir is None else float(nadir[0]), 0.0 if nadir is None else float(nadir[1]),
          nadir is not None, rays, away)
    return rays, away


@njit(cache=True)
def _rays(uv, norm, normals, pinhole, fx, fy, cx, cy, skew, R, nx, ny, has_nadir, rays,
          away):  # pragma: no cover (compiled)
    for k in range(uv.shape[0]):
        if pinhole:
            y = (uv[k, 1] - cy) / fy
            x = (uv[k, 0] - cx - skew * y) / fx
        else:
            x, y = norm[k, 0], norm[k, 1]
        d0 = R[0, 0] * x + R[0, 1] * y + R[0, 2]
        d1 = R[1, 0] * x + R[1, 1] * y + R[1, 2]
        d2 = R[2, 0] * x + R[2, 1] * y + R[2, 2]
        if abs(d2) < 1e-12:
            d2 = -1e-12
        rays[k, 0] = d0 / d2
        rays[k, 1] = d1 / d2
        away[k] = has_nadir and (normals[k, 0] * (uv[k, 0] - nx)
                                 + normals[k, 1] * (uv[k, 1] - ny)) > 0


@njit(cache=True)
def polygon_area(pts):  # pragma: no cover (compiled)
    """Unsigned area of the polygon ``pts`` (N, 2) (shoelace formula, as
    ``cv2.contourArea``), in its units squared."""
    a = 0.0
    n = pts.shape[0]
    for k in range(n):
        j = k + 1 if k + 1 < n else 0
        a += pts[k, 0] * pts[j, 1] - pts[j, 0] * pts[k, 1]
    return abs(a) / 2.0


@njit(cache=True)
def _moments(pts, s, e, ox, oy):  # pragma: no cover (compiled)
    """Signed area and first moments (mm^2, mm^3) of polygon pts[s:e] around (ox, oy)."""
    m00 = m10 = m01 = 0.0
    for k in range(s, e):
        kn = k + 1 if k + 1 < e else s
        x, y = (pts[k, 0] - ox) * 1e3, (pts[k, 1] - oy) * 1e3
        xn, yn = (pts[kn, 0] - ox) * 1e3, (pts[kn, 1] - oy) * 1e3
        c = x * yn - xn * y
        m00 += c
        m10 += (x + xn) * c
        m01 += (y + yn) * c
    return m00 / 2.0, m10 / 6.0, m01 / 6.0


@njit(cache=True)
def _by_x(px, py):  # pragma: no cover (compiled)
    """Indices of the points in increasing order of the key ``px + 1e-9 * py`` (by x,
    then y: the key's y term, points lying within metres, in mm, is far below any
    difference of x between distinct points and far above float64's resolution of x).

    A bucket sort (one bucket per point, linear in the key's range: the order of
    ``np.argsort``, up to the order of equal keys), finished by an insertion sort that
    only moves points within their bucket: linear in the points for an outline, whose
    x spread evenly, where ``np.argsort`` is n log n."""
    n = px.shape[0]
    keys = np.empty((2, n))  # the keys, then the keys in order
    key, sk = keys[0], keys[1]
    work = np.zeros(3 * n + 1, np.int64)  # bucket starts, buckets, the order
    start, bucket, order = work[: n + 1], work[n + 1 : 2 * n + 1], work[2 * n + 1 :]
    lo = hi = px[0] + 1e-9 * py[0]
    for j in range(n):
        k = px[j] + 1e-9 * py[j]
        key[j] = k
        lo = min(lo, k)
        hi = max(hi, k)
    scale = n / (hi - lo) if hi > lo else 0.0
    for j in range(n):
        f = (key[j] - lo) * scale  # monotone in the key, so the buckets are in order
        b = int(f) if f < n - 1 else n - 1
        bucket[j] = b
        start[b + 1] += 1
    for b in range(n):
        start[b + 1] += start[b]
    for j in range(n):
        q = start[bucket[j]]
        start[bucket[j]] = q + 1
        order[q] = j
        sk[q] = key[j]
    for j in range(1, n):
        i, k = order[j], sk[j]
        q = j - 1
        while q >= 0 and sk[q] > k:
            order[q + 1], sk[q + 1] = order[q], sk[q]
            q -= 1
        order[q + 1], sk[q + 1] = i, k
    return order


@njit(cache=True)
def _hull(px, py):  # pragma: no cover (compiled)
    """Convex hull (counter-clockwise from the point of least x, then y; no collinear
    points) by Andrew's monotone chain: (x, y) of its vertices."""
    n = px.shape[0]
    order = _by_x(px, py)
    hxy = np.empty((2, 2 * n + 1))
    hx, hy = hxy[0], hxy[1]
    k = 0
    for j in range(n):  # lower hull
        x, y = px[order[j]], py[order[j]]
        while k >= 2 and ((hx[k - 1] - hx[k - 2]) * (y - hy[k - 2])
                          - (hy[k - 1] - hy[k - 2]) * (x - hx[k - 2])) <= 0:
            k -= 1
        hx[k], hy[k] = x, y
        k += 1
    lower = k + 1
    for j in range(n - 2, -1, -1):  # upper hull
        x, y = px[order[j]], py[order[j]]
        while k >= lower and ((hx[k - 1] - hx[k - 2]) * (y - hy[k - 2])
                              - (hy[k - 1] - hy[k - 2]) * (x - hx[k - 2])) <= 0:
            k -= 1
        hx[k], hy[k] = x, y
        k += 1
    m = max(k - 1, 1)
    return hx[:m], hy[:m]


@njit(cache=True)
def _hull_shape(hx, hy):  # pragma: no cover (compiled)
    """(area, rectangle side along the best edge, the other side, that edge's angle,
    six-fold facet strength) of a convex polygon (counter-clockwise, no repeated points).

    The rectangle by rotating calipers (Toussaint, *Solving geometric problems with the
    rotating calipers*, 1983): for each edge the farthest points ahead, behind and across
    are found by moving three pointers forward, each once around the polygon."""
    m = hx.shape[0]
    if m < 3:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    edges = np.empty((5, m))  # edge i: from vertex i to the next, its length, direction
    ex, ey, el, ex1, ey1 = edges[0], edges[1], edges[2], edges[3], edges[4]
    area = total = re6 = im6 = 0.0
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        dx, dy = hx[j] - hx[i], hy[j] - hy[i]
        area += hx[i] * hy[j] - hx[j] * hy[i]
        length = math.sqrt(dx * dx + dy * dy)
        ex[i], ey[i], el[i] = dx, dy, length
        if length > 0.0:
            ex1[i], ey1[i] = dx / length, dy / length
            u2 = complex(ex1[i], ey1[i]) ** 2  # the direction's 6th power
            u6 = u2 * u2 * u2
            total += length
            re6 += length * u6.real
            im6 += length * u6.imag
    facets = math.sqrt(re6 * re6 + im6 * im6) / total if total > 0.0 else 0.0
    best = np.inf
    w_best = h_best = ang_best = 0.0
    ahead = across = behind = -1
    for i in range(m):
        if el[i] <= 0.0:
            continue
        ux, uy = ex1[i], ey1[i]
        if ahead < 0:  # first edge: find the three extremes by a scan
            j = i + 1 if i + 1 < m else 0
            ahead = across = behind = j
            s_ahead = s_behind = (hx[j] - hx[i]) * ux + (hy[j] - hy[i]) * uy
            t_across = -(hx[j] - hx[i]) * uy + (hy[j] - hy[i]) * ux
            for q in range(m):
                s = (hx[q] - hx[i]) * ux + (hy[q] - hy[i]) * uy
                t = -(hx[q] - hx[i]) * uy + (hy[q] - hy[i]) * ux
                if s > s_ahead:
                    ahead, s_ahead = q, s
                if t > t_across:
                    across, t_across = q, t
                if s < s_behind:
                    behind, s_behind = q, s
        else:  # each pointer moves forward (along its edge) while that improves it
            for _ in range(m):
                if ex[ahead] * ux + ey[ahead] * uy > 0:
                    ahead = ahead + 1 if ahead + 1 < m else 0
                else:
                    break
            for _ in range(m):
                if -ex[across] * uy + ey[across] * ux > 0:
                    across = across + 1 if across + 1 < m else 0
                else:
                    break
            for _ in range(m):
                if ex[behind] * ux + ey[behind] * uy < 0:
                    behind = behind + 1 if behind + 1 < m else 0
                else:
                    break
        w = ((hx[ahead] - hx[behind]) * ux + (hy[ahead] - hy[behind]) * uy)
        h = -(hx[across] - hx[i]) * uy + (hy[across] - hy[i]) * ux
        if w * h < best:
            best, w_best, h_best, ang_best = w * h, w, h, math.atan2(uy, ux)
    return abs(area) / 2.0, w_best, h_best, ang_best, facets


@njit(cache=True)
def _describe(pts, starts, outlines, out):  # pragma: no cover (compiled)
    n = outlines.shape[0]
    for i in range(n):
        last = outlines[i + 1] if i + 1 < n else starts.shape[0] - 1
        describe_one(pts, starts[outlines[i] : last + 1], out[i])


@njit(cache=True)
def describe_one(pts, pstarts, row):  # pragma: no cover (compiled)
    """Descriptors (a row of the table, see ``PolygonSet``) of one footprint whose
    outline is ``pts[pstarts[0]:pstarts[1]]`` and holes the following polygons."""
    s, e = pstarts[0], pstarts[1]
    ox, oy = pts[s, 0], pts[s, 1]
    m00, sx, sy = _moments(pts, s, e, ox, oy)
    a_out = abs(m00)
    sign = 1.0 if m00 > 0 else -1.0
    sx, sy = (sign * sx, sign * sy) if a_out >= 1e-9 else (0.0, 0.0)
    holes = hx = hy = 0.0
    for q in range(1, pstarts.shape[0] - 1):
        h00, h10, h01 = _moments(pts, pstarts[q], pstarts[q + 1], ox, oy)
        if abs(h00) >= 1e-9:
            hs = 1.0 if h00 > 0 else -1.0
            holes += abs(h00)
            hx += hs * h10
            hy += hs * h01
    net = a_out - holes
    if net > 1e-6:
        cx, cy = (sx - hx) / net, (sy - hy) / net
    elif a_out >= 1e-9:
        cx, cy = sx / a_out, sy / a_out
    else:
        cx = cy = 0.0
        for k in range(s, e):
            cx += (pts[k, 0] - ox) * 1e3
            cy += (pts[k, 1] - oy) * 1e3
        cx, cy = cx / (e - s), cy / (e - s)
    pxy = np.empty((2, e - s))  # the outline in mm around its first point
    px, py = pxy[0], pxy[1]
    for k in range(s, e):
        px[k - s] = (pts[k, 0] - ox) * 1e3
        py[k - s] = (pts[k, 1] - oy) * 1e3
    hx, hy = _hull(px, py)
    hull_area, w, hh, ang, facets = _hull_shape(hx, hy)
    if w < hh:
        w, hh, ang = hh, w, ang + math.pi / 2
    row[_AREA] = max(net, 0.0) * 1e-6
    row[_OUTER] = a_out * 1e-6
    row[_CX] = ox + cx * 1e-3
    row[_CY] = oy + cy * 1e-3
    row[_LENGTH] = w * 1e-3
    row[_WIDTH] = hh * 1e-3
    row[_ANGLE] = math.atan2(math.sin(ang), math.cos(ang))
    row[_HOLES] = 1.0 - net / a_out if a_out > 0 else 0.0
    row[_SOLIDITY] = a_out / hull_area if hull_area > 0 else 0.0
    row[_FACETS] = facets
