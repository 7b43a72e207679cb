"""The straight cuts the split stage tries on a blob's outline, generated in one compiled
pass (numba).

Given the blob's pixel outline and its convex hull, the cuts pair the six deepest
convexity defects (at least 2.5 px deep; found as ``cv2.convexityDefects`` finds them,
:mod:`cell.vision._hull`), the pairs with the shortest cut relative to their depths
first, at most six; a pair is skipped when a piece would have fewer than 8 outline
points or when the cut's midpoint lies outside the outline (``cv2.pointPolygonTest``,
ported: :func:`point_in_polygon`). Each cut runs from the outline point of the later
defect back to the earlier one, sampled every pixel as a traced boundary is, with the
outward normal of the piece that holds the outline's first points. Lengths are
CPython's ``math.hypot`` / ``math.dist`` (:func:`py_hypot`), so the cuts are those
:mod:`cell.vision._split` made point by point in Python, bit for bit.
"""

from __future__ import annotations

import math
import weakref

import numpy as np
from numba import njit

from cell.vision._footprint import Geometry, fit_arguments
from cell.vision._hull import convexity_defects
from cell.vision._polygons import _rays

__all__: list[str] = []  # private to cell.vision

_DEEP = 2.5 * 256  # defect depth (cv2's fixed point, 1/256 px) of a notch worth a cut
_DEFECTS = 6  # the deepest defects paired
_PAIRS = 6  # the best pairs tried
_MIN_RUN = 8  # outline points a piece keeps at least


@njit(cache=True)
def int_outline(contour, normals):  # pragma: no cover (compiled)
    """The outline's pixel centres: ``contour - 0.5 * normals`` rounded half to even
    (``np.round``), as int32 (N, 2)."""
    out = np.empty(contour.shape, np.int32)
    for k in range(contour.shape[0]):
        out[k, 0] = np.int32(np.rint(contour[k, 0] - 0.5 * normals[k, 0]))
        out[k, 1] = np.int32(np.rint(contour[k, 1] - 0.5 * normals[k, 1]))
    return out


@njit(cache=True)
def py_hypot(a, b):  # pragma: no cover (compiled)
    """sqrt(a^2 + b^2) as CPython 3.11's ``math.hypot`` computes it (``vector_norm`` in
    Modules/mathmodule.c: power-of-two scaling, Veltkamp-Dekker squaring, compensated
    summation, one differential correction of the root), so equal to the last bit."""
    a, b = abs(a), abs(b)
    mx = max(a, b)
    if mx == 0.0 or math.isinf(mx) or math.isnan(mx):
        return mx
    tiny = 2.2250738585072014e-308  # DBL_MIN: subnormals are scaled up first
    if mx < tiny:
        return tiny * py_hypot(a / tiny, b / tiny)
    t27 = 134217729.0  # 2^27 + 1
    scale = math.ldexp(1.0, -math.frexp(mx)[1])
    csum, frac1, frac2, frac3 = 1.0, 0.0, 0.0, 0.0
    for x in (a, b):
        x = x * scale
        t = x * t27
        hi = t - (t - x)
        lo = x - hi
        x = hi * hi
        old = csum
        csum += x
        frac1 += (old - csum) + x
        x = 2.0 * hi * lo
        old = csum
        csum += x
        frac2 += (old - csum) + x
        frac3 += lo * lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2 + frac3))
    t = h * t27
    hi = t - (t - h)
    lo = h - hi
    x = -hi * hi
    old = csum
    csum += x
    frac1 += (old - csum) + x
    x = -2.0 * hi * lo
    old = csum
    csum += x
    frac2 += (old - csum) + x
    x = -lo * lo
    old = csum
    csum += x
    frac3 += (old - csum) + x
    x = csum - 1.0 + (frac1 + frac2 + frac3)
    return (h + x / (2.0 * h)) / scale


@njit(cache=True)
def point_in_polygon(poly, px, py):  # pragma: no cover (compiled)
    """+1 inside, -1 outside, 0 on the edge of the integer polygon ``poly`` (N, 2) for a
    point on the half-pixel grid: ``cv2.pointPolygonTest(poly, (px, py), False)``
    (crossing number; exact, as OpenCV's in float32 is on such points)."""
    n = poly.shape[0]
    counter = 0
    vx, vy = float(poly[n - 1, 0]), float(poly[n - 1, 1])
    for i in range(n):
        v0x, v0y = vx, vy
        vx, vy = float(poly[i, 0]), float(poly[i, 1])
        if ((v0y <= py and vy <= py) or (v0y > py and vy > py)
                or (v0x < px and vx < px)):
            if py == vy and (px == vx or (py == v0y and ((v0x <= px <= vx) or (vx <= px <= v0x)))):
                return 0
            continue
        dist = (py - v0y) * (vx - v0x) - (px - v0x) * (vy - v0y)
        if dist == 0:
            return 0
        if vy < v0y:
            dist = -dist
        if dist > 0:
            counter += 1
    return 1 if counter % 2 == 1 else -1


@njit(cache=True)
def _pairs(outline, defects):  # pragma: no cover (compiled)
    """The pairs (first, second outline index) of the deepest defects, best first."""
    k = defects.shape[0]
    far = np.empty(k, np.int64)
    depth = np.empty(k, np.int64)
    nd = 0
    for q in range(k):  # deepest first; equal depths keep the outline's order
        d = np.int64(defects[q, 3])
        if d >= _DEEP:
            j = nd
            while j > 0 and depth[j - 1] < d:
                far[j], depth[j] = far[j - 1], depth[j - 1]
                j -= 1
            far[j], depth[j] = defects[q, 2], d
            nd += 1
    nd = min(nd, _DEFECTS)
    m = nd * (nd - 1) // 2
    ratio = np.empty(m)
    lo = np.empty(m, np.int64)
    hi = np.empty(m, np.int64)
    p = 0
    for i in range(nd):
        for j in range(i + 1, nd):
            fi, fj = far[i], far[j]
            dist = py_hypot(float(outline[fi, 0]) - float(outline[fj, 0]),
                            float(outline[fi, 1]) - float(outline[fj, 1]))
            r, a, b = dist / ((depth[i] + depth[j]) / 256.0), min(fi, fj), max(fi, fj)
            q = p  # insertion by (ratio, first, second), as Python sorts the tuples
            while q > 0 and (ratio[q - 1] > r or (ratio[q - 1] == r and (
                    lo[q - 1] > a or (lo[q - 1] == a and hi[q - 1] > b)))):
                ratio[q], lo[q], hi[q] = ratio[q - 1], lo[q - 1], hi[q - 1]
                q -= 1
            ratio[q], lo[q], hi[q] = r, a, b
            p += 1
    m = min(m, _PAIRS)
    return lo[:m], hi[:m]


@njit(cache=True)
def cut_candidates(contour, normals, outline, hull, pinhole, fx, fy, cx, cy, skew, R, nx, ny,
                   has_nadir):  # pragma: no cover (compiled)
    """The cuts of a blob (``contour``/``normals`` its outline, ``outline`` its pixel
    centres, ``hull`` their convex hull's indices; none where the hull is not monotonous,
    see :func:`convexity_defects`): per cut the outline indices
    (first, second) of its ends, its points ``cut[starts[c]:starts[c + 1]]`` from the
    second end back to the first (excluding both) with their outward normals, and, on a
    ``pinhole`` camera (``K`` entries, camera-to-world ``R``, nadir pixel), their rays
    and top-edge flags as :func:`cell.vision._polygons.plane_rays` gives them."""
    n = outline.shape[0]
    defects, ok = convexity_defects(outline, hull)
    lo, hi = _pairs(outline, defects)
    if not ok:
        lo, hi = lo[:0], hi[:0]
    # which side of the direction of travel the outward normals lie on (+1: left turn)
    side = 1.0 if ((contour[1, 0] - contour[0, 0]) * normals[0, 1]
                   - (contour[1, 1] - contour[0, 1]) * normals[0, 0]) > 0 else -1.0
    keep = np.zeros(lo.shape[0], np.bool_)
    steps = np.zeros(lo.shape[0], np.int64)
    lengths = np.ones(lo.shape[0])
    total = 0
    for c in range(lo.shape[0]):
        fi, fj = lo[c], hi[c]
        if fj - fi < _MIN_RUN or n - (fj - fi) < _MIN_RUN:
            continue
        mx = (outline[fi, 0] + outline[fj, 0]) / 2.0
        my = (outline[fi, 1] + outline[fj, 1]) / 2.0
        if point_in_polygon(outline, mx, my) < 0:
            continue  # the cut runs outside the blob
        keep[c] = True
        length = max(py_hypot(contour[fi, 0] - contour[fj, 0], contour[fi, 1] - contour[fj, 1]),
                     1e-9)
        lengths[c] = length
        steps[c] = max(int(length), 1)
        total += steps[c] - 1
    m = 0
    for c in range(lo.shape[0]):
        m += keep[c]
    first = np.empty(m, np.int64)
    second = np.empty(m, np.int64)
    starts = np.zeros(m + 1, np.int64)
    cut = np.empty((total, 2))
    out = np.empty((total, 2))
    k = e = 0
    for c in range(lo.shape[0]):
        if not keep[c]:
            continue
        fi, fj, s, length = lo[c], hi[c], steps[c], lengths[c]
        ax, ay, bx, by = contour[fj, 0], contour[fj, 1], contour[fi, 0], contour[fi, 1]
        ux, uy = -side * (by - ay) / length, side * (bx - ax) / length
        for q in range(1, s):
            t = q / s
            cut[k, 0], cut[k, 1] = ax + t * (bx - ax), ay + t * (by - ay)
            out[k, 0], out[k, 1] = ux, uy
            k += 1
        first[e], second[e] = fi, fj
        starts[e + 1] = k
        e += 1
    rays = np.empty((total, 2))
    away = np.empty(total, np.bool_)
    if pinhole:
        _rays(cut, cut, out, True, fx, fy, cx, cy, skew, R, nx, ny, has_nadir, rays, away)
    return first, second, starts, cut, out, rays, away


class SearchConstants:
    """What the compiled cut search needs of a frame's camera and settings: the pinhole
    camera's entries (as :func:`cell.vision._polygons.plane_rays` takes them), the
    compiled fit's constant arguments (:func:`~cell.vision._footprint.fit_arguments`),
    the scale from pixel to table-plane area (mm^2 per px^2, as ``Geometry.area_mm2``)."""

    def __init__(self, geo: Geometry, min_confidence: float) -> None:
        K, nadir = geo.camera.K, geo.nadir
        self.pinhole = not bool(np.any(geo.camera.dist))
        self.camera = (self.pinhole, float(K[0, 0]), float(K[1, 1]), float(K[0, 2]),
                       float(K[1, 2]), float(K[0, 1]), np.ascontiguousarray(geo.R, dtype=np.float64),
                       0.0 if nadir is None else float(nadir[0]),
                       0.0 if nadir is None else float(nadir[1]), nadir is not None)
        self.fit = fit_arguments(geo, min_confidence)
        self.area_scale = (geo.m_per_px * 1e3) ** 2


_LAST: list = [None]  # (the last geometry, weakly; its confidence limit; their constants)


def search_constants(geo: Geometry, min_confidence: float) -> SearchConstants:
    """:class:`SearchConstants` of a geometry and confidence limit, made again only when
    either changes (the detector keeps one geometry per camera). The cache is one tuple,
    read and replaced whole, so threads sharing it never mix two cameras' entries."""
    last = _LAST[0]
    if last is None or last[0]() is not geo or last[1] != min_confidence:
        last = (weakref.ref(geo), min_confidence, SearchConstants(geo, min_confidence))
        _LAST[0] = last
    return last[2]
