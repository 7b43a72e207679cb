"""Compiled kind fitting: every blob of a step mapped, described, scored and classified
in one pass (numba).

For each blob the outline's rays are intersected with the plane at mid height, the
footprint described (:func:`cell.vision._polygons.describe_one`) and scored against every
kind's nominal descriptors; the outline is then mapped again with the edge heights of
the best kind (and of the runner-up when it is close), and those footprints are scored
for their own kind. The scores are turned into a label and a confidence. This is
``cell.vision._footprint.fit_kinds`` without the Python overhead of a call per step;
the scoring is :func:`cell.vision.kind.score_kind`'s (summed squared z-scores), the
classification :func:`cell.vision.kind.classify_kind`'s.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cell.vision._polygons import describe_one

__all__: list[str] = []  # private to cell.vision

_LENGTH, _WIDTH, _ANGLE, _HOLES, _SOLIDITY, _FACETS = 4, 5, 6, 7, 8, 9
_CX, _CY = 2, 3


@njit(cache=True)
def score_rows(table, nominal, sigmas, round_, round_facets, faceted, facet_w,
               out):  # pragma: no cover (compiled)
    """Scores (n, kinds) of descriptor rows ``table`` (n, 10) against every kind."""
    for i in range(table.shape[0]):
        for k in range(nominal.shape[0]):
            out[i, k] = _score(table[i], k, nominal, sigmas, round_, round_facets, faceted, facet_w)


@njit(cache=True)
def _score(row, k, nominal, sigmas, round_, round_facets, faceted, facet_w):  # pragma: no cover
    d = (row[_LENGTH], row[_WIDTH], row[_HOLES], row[_SOLIDITY])
    s = 0.0
    for j in range(4):
        z = (d[j] - nominal[k, j]) / sigmas[k, j]
        s += z * z
    if round_[k]:
        off = row[_FACETS] - round_facets[k]
        off = min(off, 0.0) if faceted[k] else max(off, 0.0)
        s += off * off * facet_w
    return s


@njit(cache=True)
def _classify(row, max_fit):  # pragma: no cover (compiled)
    b = 0
    for k in range(1, row.shape[0]):
        if row[k] < row[b]:
            b = k
    f = row[b]
    total = 0.0
    for k in range(row.shape[0]):
        total += math.exp(-(row[k] - f) / 2)
    if f > max_fit:
        return -1, 0.0, f
    return b, 1.0 / total, f


@njit(cache=True)
def _map(rays, away, idx, s, e, lo, hi, ox, oy, drop, buf):  # pragma: no cover (compiled)
    """Points ``idx[s:e]`` of ``rays`` on the plane ``drop`` below the camera's xy
    (``ox``, ``oy``), each raised by its edge's height: ``hi[q]`` on a top edge (``away``),
    else ``lo[q]`` (m)."""
    for q in range(s, e):
        g = idx[q]
        h = hi[q - s] if away[g] else lo[q - s]
        buf[q - s, 0] = ox + (drop + h) * rays[g, 0]
        buf[q - s, 1] = oy + (drop + h) * rays[g, 1]


@njit(cache=True)
def _map_at(rays, away, idx, s, e, lo, hi, ox, oy, drop, buf):  # pragma: no cover (compiled)
    """:func:`_map` with one height ``lo`` for the edges facing the nadir and one ``hi``
    for the top edges (scalars; the same operations, so the same points to the bit)."""
    for q in range(s, e):
        g = idx[q]
        h = hi if away[g] else lo
        buf[q - s, 0] = ox + (drop + h) * rays[g, 0]
        buf[q - s, 1] = oy + (drop + h) * rays[g, 1]


@njit(cache=True)
def _bolt_heights(xy, row, height, lo, hi):  # pragma: no cover (compiled)
    """Per-point edge heights of a lying bolt from its mid-height footprint: the head
    (the wider end) stands from the belt to ``height``; the shank's silhouette lies
    between 1.5 and 8.5 mm (cell.sim.parts geometry)."""
    ax, ay = math.cos(row[_ANGLE]), math.sin(row[_ANGLE])
    n = xy.shape[0]
    s = np.empty(n)
    t = np.empty(n)
    for q in range(n):
        dx, dy = xy[q, 0] - row[_CX], xy[q, 1] - row[_CY]
        s[q] = dx * ax + dy * ay
        t[q] = abs(-dx * ay + dy * ax)
    smax, smin = s.max(), s.min()
    wide_max = wide_min = 0.0
    for q in range(n):
        if s[q] > smax - 0.004:
            wide_max = max(wide_max, t[q])
        if s[q] < smin + 0.004:
            wide_min = max(wide_min, t[q])
    at_max = wide_max > wide_min
    for q in range(n):
        head = s[q] > smax - 0.005 if at_max else s[q] < smin + 0.005
        lo[q] = 0.0 if head else 0.0015
        hi[q] = height if head else 0.0085


@njit(cache=True)
def fit_blobs(rays, away, idx, splits, counts, ox, oy, drop, mid, edge_lo, edge_hi, bolt,
              bolt_height, nominal, sigmas, round_, round_facets, faceted, facet_w, max_fit,
              hopeless, gap, min_conf, xy, starts, table, kind, conf, fit):  # pragma: no cover
    """Fit every blob; the blobs' points, one after the other (as in ``plane_footprints``),
    are ``rays[idx]``/``away[idx]``. Writes the chosen footprint's points into ``xy``,
    its polygon starts into ``starts``, its descriptors into ``table``, and kind (-1:
    unknown), confidence and fit."""
    p = 0
    k0 = 0
    starts[0] = 0
    for i in range(counts.shape[0]):
        m = counts[i]
        k1 = k0 + splits[p + m - 1]
        local = np.empty(m + 1, np.int64)
        local[0] = 0
        for j in range(m):
            local[j + 1] = splits[p + j]
            starts[p + j + 1] = k0 + splits[p + j]
        kind[i], conf[i], fit[i] = fit_one(
            rays, away, idx, k0, k1, local, ox, oy, drop, mid, edge_lo, edge_hi, bolt,
            bolt_height, nominal, sigmas, round_, round_facets, faceted, facet_w, max_fit,
            hopeless, gap, min_conf, xy[k0:k1], table[i])
        p += m
        k0 = k1


@njit(cache=True)
def fit_one(rays, away, idx, k0, k1, local, ox, oy, drop, mid, edge_lo, edge_hi, bolt,
            bolt_height, nominal, sigmas, round_, round_facets, faceted, facet_w, max_fit,
            hopeless, gap, min_conf, xy, row):  # pragma: no cover (compiled)
    """(kind or -1, confidence, fit) of the footprint of points ``idx[k0:k1]`` of
    ``rays``/``away`` (polygons at ``local``, relative); writes the chosen footprint's
    points into ``xy`` and its descriptors into ``row``."""
    n_kinds = nominal.shape[0]
    rough = np.empty(n_kinds)
    n_pts = k1 - k0
    # the mid-height footprint straight into the outputs (a refined one may replace it;
    # numba's slice copies cost far more than these element loops)
    _map_at(rays, away, idx, k0, k1, mid, mid, ox, oy, drop, xy)
    describe_one(xy, local, row)
    for k in range(n_kinds):
        rough[k] = _score(row, k, nominal, sigmas, round_, round_facets, faceted, facet_w)
    a = 0
    for k in range(1, n_kinds):
        if rough[k] < rough[a]:
            a = k
    b = 1 if a == 0 else 0
    for k in range(n_kinds):
        if k != a and rough[k] < rough[b]:
            b = k
    if rough[a] > hopeless:
        return -1, 0.0, np.inf
    tried = (a, b) if rough[b] <= rough[a] + gap else (a, -1)
    ref_xy = np.empty((2, n_pts, 2))
    ref_row = np.empty((2, 10))
    for r in range(2):
        k = tried[r]
        if k < 0:
            continue
        if k == bolt:
            lo = np.empty(n_pts)
            hi = np.empty(n_pts)
            _bolt_heights(xy, row, bolt_height, lo, hi)
            _map(rays, away, idx, k0, k1, lo, hi, ox, oy, drop, ref_xy[r])
        else:
            _map_at(rays, away, idx, k0, k1, edge_lo[k], edge_hi[k], ox, oy, drop, ref_xy[r])
        describe_one(ref_xy[r], local, ref_row[r])
        rough[k] = _score(ref_row[r], k, nominal, sigmas, round_, round_facets,
                          faceted, facet_w)
    best, c, f = _classify(rough, max_fit)
    if best < 0 or c < min_conf:
        return -1, c, f
    for r in range(2):
        if tried[r] == best:
            for q in range(n_pts):
                xy[q, 0], xy[q, 1] = ref_xy[r, q, 0], ref_xy[r, q, 1]
            for j in range(10):
                row[j] = ref_row[r, j]
    return best, c, f
