"""Straight cuts through a blob of touching parts, made and fitted in one compiled pass.

The split stage (:mod:`cell.vision._split`) tries cuts between pairs of convexity defects
of a blob's outline (:mod:`cell.vision._cutsearch`). :func:`evaluate_cuts` takes the
cuts one after another: for each it builds the two pieces (each the outline between the
defect points, closed by the cut's points, with the holes whose first point lies inside
it: a crossing-number test, as ``cv2.pointPolygonTest``), rejects specks (under 30 px^2,
shoelace area as ``cv2.contourArea``), fits each piece's kind
(:func:`cell.vision._kindfit.fit_one`) and judges the cut as the search does, and stops
at the first cut the search stops at or recurses from: one call per blob where Python
took a few dozen numpy calls per cut.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cell.vision._centroid import _moments
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
    for q in range(runs.shape[0]):  # (element by element: numba makes a view per row)
        g = runs[q]
        c[q, 0], c[q, 1] = contour[g, 0], contour[g, 1]
        nr[q, 0], nr[q, 1] = normals[g, 0], normals[g, 1]
        r[q, 0], r[q, 1] = rays[g, 0], rays[g, 1]
        aw[q] = away[g]
    for q in range(cut.shape[0]):
        k = runs.shape[0] + q
        c[k, 0], c[k, 1] = cut[q, 0], cut[q, 1]
        nr[k, 0], nr[k, 1] = cut_normals[q, 0], cut_normals[q, 1]
        r[k, 0], r[k, 1] = cut_rays[q, 0], cut_rays[q, 1]
        aw[k] = cut_away[q]
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
            r[k, 0], r[k, 1] = rays[g, 0], rays[g, 1]
            aw[k] = away[g]
            k += 1
        splits[j + 1] = k
    return c, nr, r, aw, splits, box


@njit(cache=True)
def _wrapped(a, b, n):  # pragma: no cover (compiled)
    """``np.arange(a, b) % n`` for 0 <= a < n and b <= 2 n, without the divisions."""
    out = np.empty(b - a, np.int64)
    for k in range(b - a):
        g = a + k
        out[k] = g - n if g >= n else g
    return out


@njit(cache=True)
def _run_area(contour, runs):  # pragma: no cover (compiled)
    """:func:`cell.vision._polygons.polygon_area` of ``contour[runs]``, term by term the
    same (so equal to the last bit), without the copy."""
    a = 0.0
    n = runs.shape[0]
    for k in range(n):
        p, q = runs[k], runs[k + 1 if k + 1 < n else 0]
        a += contour[p, 0] * contour[q, 1] - contour[q, 0] * contour[p, 1]
    return abs(a) / 2.0


@njit(cache=True)
def _two_pieces(contour, normals, rays, away, hole_starts, hole_first, runs0, runs1, cut,
                cut_normals, cut_rays, cut_away):  # pragma: no cover (compiled)
    """The arrays (contour, normals, rays, away, splits, box) of a cut's two pieces (piece
    0 the outline's points ``runs0`` then the ``cut``, piece 1 the points ``runs1`` then
    the cut reversed) and each piece's holes (indices)."""
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
    arrs0 = _piece(contour, normals, rays, away, hole_starts, runs0, cut, cut_normals, cut_rays,
                   cut_away, holes0)
    arrs1 = _piece(contour, normals, rays, away, hole_starts, runs1, back, back_normals,
                   back_rays, back_away, holes1)
    return arrs0, arrs1, holes0, holes1


@njit(cache=True)
def _fit_piece(arrs, ox, oy, drop, mid, edge_lo, edge_hi, bolt, bolt_height, nominal, sigmas,
               round_, round_facets, faceted, facet_w, max_fit, hopeless, gap,
               min_conf):  # pragma: no cover (compiled)
    """(kind or -1, confidence, fit, footprint points, descriptors) of one piece."""
    r, aw, splits = arrs[2], arrs[3], arrs[4]
    local = np.empty(splits.shape[0] + 1, np.int64)
    local[0] = 0
    for j in range(splits.shape[0]):
        local[j + 1] = splits[j]
    n_pts = splits[-1]
    xy = np.empty((n_pts, 2))
    row = np.empty(10)
    kind, conf, fit = fit_one(r, aw, np.arange(n_pts), 0, n_pts, local, ox, oy, drop, mid,
                              edge_lo, edge_hi, bolt, bolt_height, nominal, sigmas, round_,
                              round_facets, faceted, facet_w, max_fit, hopeless, gap, min_conf,
                              xy, row)
    return kind, conf, fit, xy, row


@njit(cache=True)
def _area_mm2(contour, holes, hole_pts, hole_off, area_scale):  # pragma: no cover (compiled)
    """A piece's table-plane area (outline less ``holes``, shoelace, times
    ``area_scale``), as ``Geometry.area_mm2`` computes it, to the last bit."""
    a = polygon_area(contour)
    for h in holes:
        a -= polygon_area(hole_pts[hole_off[h] : hole_off[h + 1]])
    return a * area_scale


@njit(cache=True)
def _centroid_of(contour, holes, hole_pts, hole_off):  # pragma: no cover (compiled)
    """(found, u, v): a piece's pixel centroid, the sums of
    :func:`cell.vision._centroid.blob_centroid` in its order (found 0.0 where the area is
    below 1e-9: the caller asks that function)."""
    a, cx, cy = _moments(contour, 0, contour.shape[0])
    for h in holes:
        m00, m10, m01 = _moments(hole_pts, hole_off[h], hole_off[h + 1])
        a, cx, cy = a - m00, cx - m10, cy - m01
    if abs(a) < 1e-9:
        return 0.0, 0.0, 0.0
    return 1.0, cx / a, cy / a


@njit(cache=True)
def _grown(a, used, need):  # pragma: no cover (compiled)
    """(2, k, 2) array ``a`` with its first ``used`` points, enlarged to hold ``need``."""
    out = np.empty((2, max(need, 2 * a.shape[1]), 2))
    out[:, :used] = a[:, :used]
    return out


@njit(cache=True)
def _store(p, arrs, holes, kind, conf, fit, xy, row, area, hole_pts, hole_off, meta, scores,
           cn_all, rxy_all, aw_all, kc, kr):  # pragma: no cover (compiled)
    """Write piece ``p`` (with its ``area`` and pixel centroid) into the output arrays at
    offsets (kc, kr); the new offsets."""
    pc, pn, pr, paw, psplits, box = arrs
    nc, nrays, nh = pc.shape[0], pr.shape[0], holes.shape[0]
    for q in range(nc):  # (element by element: numba's slice copies cost far more)
        cn_all[0, kc + q, 0], cn_all[0, kc + q, 1] = pc[q, 0], pc[q, 1]
        cn_all[1, kc + q, 0], cn_all[1, kc + q, 1] = pn[q, 0], pn[q, 1]
    for q in range(nrays):
        rxy_all[0, kr + q, 0], rxy_all[0, kr + q, 1] = pr[q, 0], pr[q, 1]
        rxy_all[1, kr + q, 0], rxy_all[1, kr + q, 1] = xy[q, 0], xy[q, 1]
        aw_all[kr + q] = paw[q]
    meta[p, 0], meta[p, 1], meta[p, 2], meta[p, 3] = kc, kc + nc, kr, kr + nrays
    meta[p, 4], meta[p, 5] = kind, nh
    meta[p, 6:10] = box
    meta[p, 10 : 10 + psplits.shape[0]] = psplits
    held = 11 + (meta.shape[1] - 11) // 2  # the holes' first column
    meta[p, held : held + nh] = holes
    scores[p, 0], scores[p, 1] = conf, fit
    for j in range(10):
        scores[p, 2 + j] = row[j]
    scores[p, 12], scores[p, 13], scores[p, 14] = _centroid_of(pc, holes, hole_pts, hole_off)
    scores[p, 15] = area
    return kc + nc, kr + nrays


@njit(cache=True)
def evaluate_cuts(contour, normals, rays, away, hole_starts, hole_pts, first, second,
                  starts, cut, cut_normals, cut_rays, cut_away, begin, count, may_split,
                  area_scale, min_pair, good, ox, oy, drop, mid, edge_lo, edge_hi, bolt,
                  bolt_height, nominal, sigmas, round_, round_facets, faceted, facet_w, max_fit,
                  hopeless, gap, min_conf):  # pragma: no cover (compiled)
    """Build and fit the pieces of cuts ``begin``, ``begin + 1``, ... of a prepared blob
    (``contour``/``normals`` its outline, ``rays``/``away`` outline then holes, hole h's
    points at ``hole_starts[h]`` up to ``hole_starts[h + 1]`` in those, its outline
    ``hole_pts`` from ``hole_starts[h] - n``). Cut c
    joins outline points ``first[c]`` < ``second[c]``: piece 0 is the outline from the
    first to the second then the cut's points ``cut[starts[c]:starts[c + 1]]`` (with
    their normals, rays, top-edge flags), piece 1 the outline from the second round to
    the first then the cut reversed; each takes the holes whose first point lies inside
    it (its first point: a crossing-number test, as ``cv2.pointPolygonTest``). A cut
    fails when a piece is a speck (under 30 px^2, as ``cv2.contourArea``) or fits no kind
    and may not be split (``may_split`` False, or its area (:func:`_area_mm2`) at most
    ``min_pair``; the second piece is then not fitted).

    Stops after ``count`` cuts, or after a cut the search will not go past: both pieces
    fit a kind with a mean fit below ``good``, or a piece fits none (and may be split).
    Returns (meta, scores, cn, rxy, aw), few arrays (each costs its boxing): per piece
    (cut c's are rows 2c and 2c + 1) ``meta`` (contour start/end in ``cn``, point
    start/end in ``rxy``/``aw``, kind or -1 (-2: the cut failed), how many holes it
    holds (k), bounding box as ``cv2.boundingRect``, then from column 10 its cumulative
    polygon sizes (k + 1) and from column 11 + the blob's holes its holes' indices (k)),
    ``scores`` (confidence, fit, 10 descriptors, then the pixel centroid as found (1.0 or
    0.0: :func:`_centroid_of`), u, v, and the table-plane area (mm^2)), then the pieces'
    points concatenated: ``cn`` their outlines and normals (2, points, 2), ``rxy`` their
    rays and footprint points (2, points, 2) and ``aw`` their top-edge flags."""
    n = contour.shape[0]
    n_holes = hole_starts.shape[0] - 1
    hole_off = hole_starts - n
    hole_first = np.empty((n_holes, 2))
    for h in range(n_holes):
        hole_first[h, 0], hole_first[h, 1] = hole_pts[hole_off[h], 0], hole_pts[hole_off[h], 1]
    m = min(first.shape[0], begin + count)
    pieces = 2 * (m - begin)
    meta = np.zeros((pieces, 11 + 2 * n_holes), np.int64)
    scores = np.zeros((pieces, 16))
    # room for one cut's pieces (the search mostly stops at the first); more on demand
    size_c = n + 2 + 2 * (starts[begin + 1] - starts[begin]) if m > begin else 0
    size_r = size_c + 2 * (rays.shape[0] - n)
    cn_all = np.empty((2, size_c, 2))
    rxy_all = np.empty((2, size_r, 2))
    aw_all = np.empty(size_r, np.bool_)
    kc = kr = 0
    done = 0
    for c in range(begin, m):
        fi, fj = first[c], second[c]
        p = 2 * done
        done += 1
        meta[p, 4] = meta[p + 1, 4] = -2  # until both pieces are in
        s, e = starts[c], starts[c + 1]
        runs0, runs1 = np.arange(fi, fj + 1), _wrapped(fj, n + fi + 1, n)
        if _run_area(contour, runs0) < 30 or _run_area(contour, runs1) < 30:
            continue
        arrs0, arrs1, holes0, holes1 = _two_pieces(
            contour, normals, rays, away, hole_starts, hole_first, runs0, runs1, cut[s:e],
            cut_normals[s:e], cut_rays[s:e], cut_away[s:e])
        kind0, conf0, fit0, xy0, row0 = _fit_piece(
            arrs0, ox, oy, drop, mid, edge_lo, edge_hi, bolt, bolt_height, nominal, sigmas,
            round_, round_facets, faceted, facet_w, max_fit, hopeless, gap, min_conf)
        area0 = _area_mm2(arrs0[0], holes0, hole_pts, hole_off, area_scale)
        if kind0 < 0 and not (may_split and area0 > min_pair):
            continue
        kind1, conf1, fit1, xy1, row1 = _fit_piece(
            arrs1, ox, oy, drop, mid, edge_lo, edge_hi, bolt, bolt_height, nominal, sigmas,
            round_, round_facets, faceted, facet_w, max_fit, hopeless, gap, min_conf)
        area1 = _area_mm2(arrs1[0], holes1, hole_pts, hole_off, area_scale)
        if kind1 < 0 and not (may_split and area1 > min_pair):
            continue
        need_c = kc + arrs0[0].shape[0] + arrs1[0].shape[0]
        need_r = kr + arrs0[2].shape[0] + arrs1[2].shape[0]
        if need_c > cn_all.shape[1]:
            cn_all = _grown(cn_all, kc, need_c)
        if need_r > rxy_all.shape[1]:
            rxy_all = _grown(rxy_all, kr, need_r)
            aw = np.empty(rxy_all.shape[1], np.bool_)
            aw[:kr] = aw_all[:kr]
            aw_all = aw
        kc, kr = _store(p, arrs0, holes0, kind0, conf0, fit0, xy0, row0, area0, hole_pts,
                        hole_off, meta, scores, cn_all, rxy_all, aw_all, kc, kr)
        kc, kr = _store(p + 1, arrs1, holes1, kind1, conf1, fit1, xy1, row1, area1, hole_pts,
                        hole_off, meta, scores, cn_all, rxy_all, aw_all, kc, kr)
        if kind0 < 0 or kind1 < 0 or (fit0 + fit1) / 2 < good:
            break
    pieces = 2 * done
    return meta[:pieces], scores[:pieces], cn_all[:, :kc], rxy_all[:, :kr], aw_all[:kr]
