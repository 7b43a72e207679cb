"""A blob's first batch of straight cuts, from its outline to the fitted pieces, in one
compiled call (numba).

The split stage (:mod:`cell.vision._split`) tries cuts between pairs of convexity
defects of a blob's outline. Their making takes four kernels (the outline's pixel
centres, :func:`cell.vision._cutsearch.int_outline`; their convex hull,
:func:`cell.vision._hull.convex_hull`; the cuts, :func:`cell.vision._cutsearch.cut_candidates`;
the pieces built and fitted, :func:`cell.vision._cutfit.evaluate_cuts`); most blobs are
settled by the first batch, so :func:`first_cuts` runs all four in one call, each
Python call of a kernel with dozens of arguments costing microseconds.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cell.vision._cutfit import evaluate_cuts
from cell.vision._cutsearch import cut_candidates, int_outline
from cell.vision._hull import convex_hull

__all__: list[str] = []  # private to cell.vision


@njit(cache=True)
def first_cuts(contour, normals, rays, away, hole_starts, hole_pts, count, may_split,
               area_scale, min_pair, good, pinhole, fx, fy, cx, cy, skew, R, nx, ny, has_nadir,
               ox, oy, drop, mid, edge_lo, edge_hi, bolt, bolt_height, nominal, sigmas, round_,
               round_facets, faceted, facet_w, max_fit, hopeless, gap,
               min_conf):  # pragma: no cover (compiled)
    """A prepared blob's cuts (:func:`cell.vision._cutsearch.cut_candidates` on a
    ``pinhole`` camera) and the first batch of them built and fitted
    (:func:`cell.vision._cutfit.evaluate_cuts` from cut 0, at most ``count``; the
    arguments are theirs). Returns (status, index, points, away, evaluation): status 1
    with the cuts, 0 where there are none (an outline of fewer than 5 points, a hull of
    fewer than 4 vertices), -1 where the hull is not plain
    (:func:`cell.vision._hull.convex_hull`: OpenCV must make it); the cuts (``index``:
    first, second and starts one after the other; ``points`` (3, k, 2): the cut, normals
    and rays) and the evaluation are empty unless the status is 1. (Few arrays: each
    costs its boxing.)"""
    outline = int_outline(contour, normals)
    status = 0
    hull = np.empty(0, np.int32)
    if outline.shape[0] >= 5:
        hull = convex_hull(outline)
        if hull.shape[0] == 0:
            status = -1
        elif hull.shape[0] >= 4:
            status = 1
    if status != 1:
        hull = np.empty(0, np.int32)  # (no defects: no cuts)
    first, second, starts, cut, cut_normals, cut_rays, cut_away = cut_candidates(
        contour, normals, outline, hull, pinhole, fx, fy, cx, cy, skew, R, nx, ny, has_nadir)
    res = evaluate_cuts(contour, normals, rays, away, hole_starts, hole_pts, first, second,
                        starts, cut, cut_normals, cut_rays, cut_away, 0, count, may_split,
                        area_scale, min_pair, good, ox, oy, drop, mid, edge_lo, edge_hi, bolt,
                        bolt_height, nominal, sigmas, round_, round_facets, faceted, facet_w,
                        max_fit, hopeless, gap, min_conf)
    m = first.shape[0]
    index = np.empty(3 * m + 1, np.int64)
    for c in range(m):  # (element by element: numba's slice copies cost far more)
        index[c], index[m + c] = first[c], second[c]
    for c in range(m + 1):
        index[2 * m + c] = starts[c]
    points = np.empty((3, cut.shape[0], 2))
    for q in range(cut.shape[0]):
        points[0, q, 0], points[0, q, 1] = cut[q, 0], cut[q, 1]
        points[1, q, 0], points[1, q, 1] = cut_normals[q, 0], cut_normals[q, 1]
        points[2, q, 0], points[2, q, 1] = cut_rays[q, 0], cut_rays[q, 1]
    return status, index, points, cut_away, res
