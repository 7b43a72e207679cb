"""A straight cut through a blob of touching parts, made and fitted in one compiled pass.

The split stage (:mod:`cell.vision._split`) tries cuts between pairs of convexity defects
of a blob's outline. For one cut, :func:`cut_pieces` builds the two pieces (each the
outline between the defect points, closed by the cut's points, with the holes whose first
point lies inside it: a crossing-number test, as ``cv2.pointPolygonTest``), rejects specks
(under 30 px^2, shoelace area as ``cv2.contourArea``) and fits each piece's kind
(:func:`cell.vision._kindfit.fit_one`), all in numba: in Python the same took a few dozen
numpy calls per cut.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cell.vision._kindfit import fit_one
from cell.vision._polygons import polygon_area

__all__: list[str] = []  # private to cell.vision


@njit(cache=True)
def _inside(px, py, contour, runs, cut):  # pragma: no cover (compiled)
    """Whether (px, py) is inside the polygon of ``contour``'s index ``runs`` followed by
    the ``cut`` points (crossing number, Shimrat 1962)."""
    inside = False
    n_run = runs.shape[0]
    total = n_run + cut.shape[0]
    for e in range(total):
        f = e + 1 if e + 1 < total else 0
        ax = contour[runs[e], 0] if e < n_run else cut[e - n_run, 0]
        ay = contour[runs[e], 1] if e < n_run else cut[e - n_run, 1]
        bx = contour[runs[f], 0] if f < n_run else cut[f - n_run, 0]
        by = contour[runs[f], 1] if f < n_run else cut[f - n_run, 1]
        if (ay > py) != (by > py):
            x = ax + (py - ay) * (bx - ax) / (by - ay)
            if x > px:
                inside = not inside
    return inside


@njit(cache=True)
def _piece(contour, normals, rays, away, hole_starts, runs, cut, cut_normals, cut_rays, cut_away,
           holes):  # pragma: no cover (compiled)
    """The arrays (contour, normals, rays, away, splits) of one piece: the outline's
    points ``runs``, the cut's points, then the listed ``holes``' points."""
    n = runs.shape[0] + cut.shape[0]
    total = n
    for j in range(holes.shape[0]):
        total += hole_starts[holes[j] + 1] - hole_starts[holes[j]]
    c = np.empty((n, 2))
    nr = np.empty((n, 2))
    r = np.empty((total, 2))
    aw = np.empty(total, np.bool_)
    splits = np.empty(1 + holes.shape[0], np.int64)
    for q in range(runs.shape[0]):
        g = runs[q]
        c[q], nr[q], r[q], aw[q] = contour[g], normals[g], rays[g], away[g]
    for q in range(cut.shape[0]):
        k = runs.shape[0] + q
        c[k], nr[k], r[k], aw[k] = cut[q], cut_normals[q], cut_rays[q], cut_away[q]
    splits[0] = n
    box = np.empty(4, np.int64)  # as cv2.boundingRect of the float32 outline
    xmin = xmax = np.floor(np.float32(c[0, 0]))
    ymin = ymax = np.floor(np.float32(c[0, 1]))
    for q in range(1, n):
        x, y = np.floor(np.float32(c[q, 0])), np.floor(np.float32(c[q, 1]))
        xmin, xmax, ymin, ymax = min(xmin, x), max(xmax, x), min(ymin, y), max(ymax, y)
    box[0], box[1] = int(xmin), int(ymin)
    box[2], box[3] = int(xmax - xmin) + 1, int(ymax - ymin) + 1
    k = n
    for j in range(holes.shape[0]):
        h = holes[j]
        for g in range(hole_starts[h], hole_starts[h + 1]):
            r[k], aw[k] = rays[g], away[g]
            k += 1
        splits[j + 1] = k
    return c, nr, r, aw, splits, box


@njit(cache=True)
def cut_pieces(contour, normals, rays, away, hole_starts, hole_first, runs0, runs1, cut,
               cut_normals, cut_rays, cut_away, ox, oy, drop, mid, edge_lo, edge_hi, bolt,
               bolt_height, nominal, sigmas, round_, round_facets, faceted, facet_w,
               max_fit, hopeless, gap, min_conf):  # pragma: no cover (compiled)
    """The two pieces of a cut of a prepared blob (``contour``/``normals`` its outline,
    ``rays``/``away`` outline then holes, hole h's points at ``hole_starts[h]`` up to
    ``hole_starts[h + 1]`` in those, its first pixel ``hole_first[h]``): piece 0 is the
    outline's points ``runs0`` then the ``cut`` (with its normals, rays, top-edge flags),
    piece 1 the points ``runs1`` then the cut reversed. Returns None for a speck, else
    per piece (arrays, bounding box, kind or -1, confidence, fit, footprint points,
    descriptors) and each piece's holes (indices)."""
    if (polygon_area(contour[runs0]) < 30 or polygon_area(contour[runs1]) < 30):
        return None
    back = cut[::-1].copy()
    back_normals = -cut_normals[::-1]
    back_rays = cut_rays[::-1].copy()
    back_away = ~cut_away[::-1]
    n_holes = hole_first.shape[0]
    in0 = np.zeros(n_holes, np.bool_)
    in1 = np.zeros(n_holes, np.bool_)
    for h in range(n_holes):  # each piece takes the holes inside it (tested for each)
        in0[h] = _inside(hole_first[h, 0], hole_first[h, 1], contour, runs0, cut)
        in1[h] = _inside(hole_first[h, 0], hole_first[h, 1], contour, runs1, back)
    holes0, holes1 = np.nonzero(in0)[0], np.nonzero(in1)[0]
    out = []
    for which in range(2):
        if which == 0:
            arrs = _piece(contour, normals, rays, away, hole_starts, runs0, cut, cut_normals,
                          cut_rays, cut_away, holes0)
        else:
            arrs = _piece(contour, normals, rays, away, hole_starts, runs1, back, back_normals,
                          back_rays, back_away, holes1)
        c, nr, r, aw, splits, box = arrs
        local = np.empty(splits.shape[0] + 1, np.int64)
        local[0] = 0
        local[1:] = splits
        n_pts = splits[-1]
        xy = np.empty((n_pts, 2))
        row = np.empty(10)
        kind, conf, fit = fit_one(r, aw, np.arange(n_pts), 0, n_pts, local, ox, oy, drop, mid,
                                  edge_lo, edge_hi, bolt, bolt_height, nominal, sigmas, round_,
                                  round_facets, faceted, facet_w, max_fit, hopeless, gap,
                                  min_conf, xy, row)
        out.append((c, nr, r, aw, splits, box, kind, conf, fit, xy, row))
    return out[0], out[1], holes0, holes1
