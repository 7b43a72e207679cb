"""Touching parts: cut a blob that fits no kind into pieces that each fit one.

Candidates: cuts between pairs of deep convexity defects (two convex parts that touch
leave a notch on each side of the contact; the shortest cuts between deep notches are
tried first), then cores of the distance transform at a few depths (erosion-based
separation; Gonzalez & Woods, *Digital Image Processing*, ch. 9-10), every pixel going
to its nearest core; last, where neither gave pieces that fit, a cut along the blob's
colours (two finishes: :mod:`cell.vision._colourcut`). The candidate whose pieces fit
their kinds best wins. A piece that fits no kind is split again (chains of up to four
parts) when it is large enough to hold two parts; one that fits a kind poorly only when
no cut's pieces fit well as they are. The outline cuts are generated, built and fitted
in compiled passes (:mod:`cell.vision._cutsearch`, :mod:`cell.vision._cutfit`; a blob's
first batch in one call, :mod:`cell.vision._cutblob`), the cores' pieces found and
outlined in one (:mod:`cell.vision._cutraster`); the search itself stays here.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from cell.camera import CameraModel
from cell.vision._blob import Blob
from cell.vision._blobwindows import blobs_of_mask
from cell.vision._centroid import blob_centroid
from cell.vision._colourcut import colour_seeds
from cell.vision._cutblob import first_cuts
from cell.vision._cutfit import evaluate_cuts
from cell.vision._cutraster import owned_pieces, piece_blobs
from cell.vision._cutsearch import cut_candidates, int_outline, search_constants
from cell.vision._footprint import Fit, Geometry, fit_kinds
from cell.vision._hull import convex_hull
from cell.vision._polyfill import fill_within
from cell.vision._segment import FrameView
from cell.vision.kind import KIND_NAMES

__all__: list[str] = []  # private to cell.vision

# Mean piece fit at which a cut is taken without trying more (a fit of 4 to 6 gave the same
# detections' kinds, materials and counts on the bench's scenes, 7 lost one kind).
_GOOD = 6.0
_ACCEPT = 9.0  # a piece (or a cut, on average) fitting worse than this fits no kind
# Two parts cover at least this table-plane area (mm^2): twice the smallest nominal
# footprint (a square nut, 119 mm^2) less a margin; a smaller piece is not split again.
_MIN_PAIR_MM2 = 200.0
# Pieces of pieces are cut along the outline only: on the bench's scenes (tune and held-out
# sets) raster cores there found no cut the outline cuts had missed, and cost a third of
# the split stage under raking light.
_CORE_DEPTH = 1
# The raster cores are not tried when the outline cuts already gave pieces that fit this
# well on average (a fraction of the search's limit): on the bench's scenes they then never
# found a better cut that changed a detection's kind, material or count (a stricter 1.0
# cost accuracy), and they are a third of a blob's search.
_CORE_SKIP = 0.7
# The colour cut is tried on a blob, not on its pieces: on four scene sets under raking
# light (870 parts) it found 11 more parts there too (clusters of three), but it made the
# split stage half as slow again.
_COLOUR_DEPTH = 1
# The most cuts one blob's search (all depths together) evaluates: the search is an anytime
# one, the best cut found so far wins. A blob of touching parts needs a handful; a blob
# that is no set of parts would otherwise try every cut of every piece.
_BUDGET = 24
# A blob that fits one kind poorly (fit >= 9) is still cut when the cut's pieces fit
# this much better on average, up to a mean fit of _POOR (dim frames blur every outline).
_BETTER = 2.0
_POOR = 13.0

_NO_HOLES = np.empty((0, 2))

# blob, kind, confidence, footprint, fit, table-plane area (mm^2)
Piece = tuple[Blob, str, float, Fit, float, float]


def split_blob(blob: Blob, view: FrameView, *,
               whole_fit: float = math.inf) -> list[tuple[Blob, str, float, Fit]]:
    """Pieces (blob, kind, confidence, footprint with the piece's pixel centroid) of a
    blob of touching parts, or [] when no cut gives pieces that fit their kinds (mean fit
    below ``_ACCEPT``), or when the blob is too small to hold two parts."""
    limit = _ACCEPT
    if math.isfinite(whole_fit):  # the whole blob fits a kind, poorly: a clearly better cut wins
        limit = max(_ACCEPT, min(whole_fit - _BETTER, _POOR))
    if view.geo.area_mm2(blob) <= _MIN_PAIR_MM2:
        return []
    pieces = _split(blob, view, 0, [_BUDGET], limit)
    for p in pieces:  # (every piece's blob comes with its centroid computed)
        p[3].centroid_px = blob_centroid(p[0])
    return [p[:4] for p in pieces]


def _split(blob: Blob, view: FrameView, depth: int, budget: list[int],
           limit: float = _ACCEPT) -> list[Piece]:
    """:func:`split_blob` at recursion ``depth``, of a blob larger than ``_MIN_PAIR_MM2``,
    each piece with its fit score; ``budget`` holds how many more cuts the whole search
    may evaluate."""
    best: list[Piece] = []
    best_cost = math.inf
    deferred: list[list[Piece]] = []  # cuts with a piece that may split further

    def cores() -> bool:  # asked once the outline cuts are done: is a raster cut worth it?
        return depth < _CORE_DEPTH and best_cost >= _CORE_SKIP * limit

    def colour() -> bool:  # asked last: has no cut of the blob itself given pieces that fit?
        return depth < _COLOUR_DEPTH and best_cost >= limit

    for pieces in _candidates(blob, view, depth < 2, cores, colour, budget):
        if pieces is None:
            continue
        if any(p[1] == "unknown" for p in pieces):  # (each may split: else _evaluate is None)
            pieces = _split_further(pieces, view, depth, budget, unknown_only=True)
            if not pieces:
                continue
        cost = sum(p[4] for p in pieces) / len(pieces)
        if cost < best_cost:
            best, best_cost = pieces, cost
        if best_cost < _GOOD:
            break  # every piece fits its kind well: no need to try more cuts
        if depth < 2 and any(p[4] >= _ACCEPT and _may_split(p) for p in pieces):
            deferred.append(pieces)
    if best_cost >= _GOOD:
        for pieces in deferred:  # the cuts whose ill-fitting pieces may be parts touching
            out = _split_further(pieces, view, depth, budget)
            if not out:
                continue
            cost = sum(p[4] for p in out) / len(out)
            if cost < best_cost:
                best, best_cost = out, cost
            if best_cost < _GOOD:
                break
    if best_cost >= limit:
        return []
    for p in best:
        if p[0].roi is None:
            p[0].roi = _piece_roi(p[0], blob)
    return best


def _may_split(piece: Piece) -> bool:
    return piece[5] > _MIN_PAIR_MM2


def _split_further(pieces: list[Piece], view: FrameView, depth: int, budget: list[int], *,
                   unknown_only: bool = False) -> list[Piece]:
    """The pieces with each unknown one (and unless ``unknown_only`` each ill-fitting
    one) replaced by its own pieces; [] when an unknown piece does not split."""
    out: list[Piece] = []
    for p in pieces:
        if p[1] != "unknown" and (unknown_only or p[4] < _ACCEPT):
            out.append(p)
            continue
        more = _split(p[0], view, depth + 1, budget) if _may_split(p) else []
        if more:
            out.extend(more)
        elif p[1] == "unknown":
            return []
        else:
            out.append(p)
    return out


def _candidates(blob: Blob, view: FrameView, may_split: bool, cores, colour,
                budget: list[int]):
    """Evaluated cuts of a blob (lists of pieces, or None for a cut that fails), best
    guesses first: straight cuts between pairs of deep convexity defects, made on the
    outline itself (:func:`_polygon_cuts`); then, when ``cores()`` says so after those,
    cores of the distance transform, on the rasterised blob (:func:`_core_cuts`); last,
    when ``colour()`` says so (no cut so far gave pieces that fit), one cut along the
    blob's colours (:func:`cell.vision._colourcut.colour_seeds`), outside the budget."""
    geo, conf = view.geo, view.settings.min_kind_confidence
    for pieces in _polygon_cuts(blob, geo, conf, may_split, budget):
        if budget[0] <= 0:
            break
        budget[0] -= 1
        yield pieces
    rasters = None
    if budget[0] > 0 and cores():
        rasters = _rasters(blob)
        roi, filled, offset = rasters
        done: dict[bytes, list[Piece] | None] = {}  # the cuts so far, by their pieces' pixels
        for seeds in _core_cuts(filled):
            if budget[0] <= 0:
                break
            budget[0] -= 1
            masks, counts = owned_pieces(roi, seeds)
            key = masks.tobytes()  # a deeper level's cores often own the same pieces
            if key not in done:
                pieces = piece_blobs(masks, counts, offset, view.geo)
                done[key] = None if pieces is None else _evaluate(pieces, view, may_split)
            yield done[key]
    if colour():
        roi, _, offset = rasters if rasters is not None else _rasters(blob)
        seeds = colour_seeds(view.img, roi, *offset)
        if seeds is not None:
            pieces = piece_blobs(*owned_pieces(roi, seeds), offset, view.geo)
            if pieces is not None:
                yield _evaluate(pieces, view, may_split)


def _rasters(blob: Blob) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """(roi, filled, offset) of a blob: its pixels (uint8 0/255, holes 0) and the same
    with its holes filled (a washer's core is its whole disc), with a 1 px blank border;
    ``offset`` the frame position of their top-left corner."""
    x, y, bw, bh = blob.mask_box
    ox, oy = x - 1, y - 1
    roi = np.zeros((bh + 2, bw + 2), np.uint8)
    cv2.drawContours(roi, [int_outline(blob.contour, blob.normals)], -1, 255, -1,
                     offset=(-ox, -oy))
    filled = roi.copy()
    for hole, hn in blob.holes:
        cv2.drawContours(roi, [int_outline(hole, hn)], -1, 0, -1, offset=(-ox, -oy))
    return roi, filled, (ox, oy)


def _polygon_cuts(blob: Blob, geo: Geometry, min_confidence: float, may_split: bool,
                  budget: list[int]):
    """Pieces (two, or None for a cut with a speck or with a piece that fits no kind and
    may not be split) of straight cuts between pairs of deep (>= 2.5 px) convexity defects
    of the outline (``cv2.convexHull`` and ``cv2.convexityDefects`` as ported in
    :mod:`cell.vision._hull`; :mod:`cell.vision._cutsearch` makes the cuts).
    A piece is the outline between the two defect points, closed by the cut, with the
    holes inside it; its rays come from the blob's (no new contour tracing). The cuts
    are built and fitted in batches (:func:`cell.vision._cutfit.evaluate_cuts`), each
    up to the next cut the search in :func:`_split` may stop at or recurse from."""
    if budget[0] <= 0:
        return
    if blob.rays is None:
        geo.prepare([blob])
    k = search_constants(geo, min_confidence)
    hole_pts = np.concatenate([h for h, _ in blob.holes]) if blob.holes else _NO_HOLES
    status, res = -1, None
    if k.pinhole:  # the usual case: the cuts and their first batch in one call
        status, index, points, away, res = first_cuts(
            blob.contour, blob.normals, blob.rays, blob.away, blob.splits, hole_pts,
            budget[0], may_split, k.area_scale, _MIN_PAIR_MM2, _GOOD, *k.camera, *k.fit)
        m = (len(index) - 1) // 3
        first, second, starts = index[:m], index[m : 2 * m], index[2 * m :]
        cut, normals, rays = points[0], points[1], points[2]
    if status == 0:
        return
    if status < 0:  # another camera model, or a hull OpenCV must make
        res = None
        outline = int_outline(blob.contour, blob.normals)
        if len(outline) < 5:
            return
        hull = convex_hull(outline)
        if len(hull) == 0:  # not plain: OpenCV decides
            hull = cv2.convexHull(outline, returnPoints=False)
            hull = np.empty(0, np.int32) if hull is None else hull.reshape(-1)
        if len(hull) < 4:
            return
        first, second, starts, cut, normals, rays, away = cut_candidates(
            blob.contour, blob.normals, outline, hull, *k.camera)
        if not k.pinhole:
            rays, away = geo.plane_rays(cut, normals)
    ends = starts.tolist()
    c = 0
    while c < len(ends) - 1 and budget[0] > 0:
        if res is None:
            res = evaluate_cuts(blob.contour, blob.normals, blob.rays, blob.away, blob.splits,
                                hole_pts, first, second, starts, cut, normals, rays, away, c,
                                budget[0], may_split, k.area_scale, _MIN_PAIR_MM2, _GOOD, *k.fit)
        meta, scores = res[0].tolist(), res[1].tolist()
        for p in range(0, len(meta), 2):
            yield _batch_pieces(blob, res, meta, scores, p, ends[c + 1] - ends[c])
            c += 1
        res = None


def _batch_pieces(blob: Blob, res: tuple, meta: list, scores: list, p: int,
                  cut: int) -> list[Piece] | None:
    """The two pieces, with their best kinds, of the cut whose pieces are rows ``p`` and
    ``p + 1`` of an :func:`~cell.vision._cutfit.evaluate_cuts` result (``meta`` and
    ``scores`` its first two arrays as lists); None when the cut failed (a piece is a
    speck, or fits no kind and may not be split, as :func:`_judge` finds). ``cut``: each
    piece's outline ends with that many points of the cut."""
    if meta[p][4] == -2:
        return None
    imeta, rows, cn, rxy, aw = res
    c, nr, r, xy = cn[0], cn[1], rxy[0], rxy[1]
    held = 11 + len(blob.holes)  # the column of a piece's first hole in meta
    out = []
    for q in (p, p + 1):
        mq = meta[q]
        c0, c1, r0, r1, kind, nh, bx, by, bw, bh = mq[:10]
        sq = scores[q]
        holes = [blob.holes[h] for h in mq[held : held + nh]] if nh else []
        spl = imeta[q, 10 : 11 + nh]
        piece = Blob(c[c0:c1], nr[c0:c1], holes, (bx, by, bw, bh), False, None, r[r0:r1],
                     aw[r0:r1], spl, centroid_px=(sq[13], sq[14]) if sq[12] else None)
        fit = Fit(rows[q, 2:12], xy[r0:r1], tuple(mq[10 : 11 + nh]), cut=cut)
        out.append((piece, KIND_NAMES[kind] if kind >= 0 else "unknown", sq[0], fit, sq[1],
                    sq[15]))
    return out


def _piece_roi(piece: Blob, parent: Blob) -> tuple[int, int, np.ndarray] | None:
    """A polygon piece's own pixels: its outline filled, within the parent's pixels
    (:func:`cell.vision._polyfill.fill_within`: ``cv2.fillPoly`` and ``cv2.bitwise_and``
    in one compiled call)."""
    if parent.roi is None:
        return None
    x0, y0, mask = parent.roi
    ok, own = fill_within(mask, piece.contour, piece.normals, x0, y0)
    if not ok:  # the outline leaves the parent's box: OpenCV clips it
        own = np.zeros_like(mask)
        cv2.fillPoly(own, [int_outline(piece.contour, piece.normals)], 255, offset=(-x0, -y0))
        own = cv2.bitwise_and(own, mask)
    return x0, y0, own


def _core_cuts(roi: np.ndarray):
    """Seed images (uint8, pieces labelled 1..n) of the distance transform's cores of a
    filled blob at a few depths (3, 5, 8, 12 px) that give two or three cores."""
    dist = cv2.distanceTransform(roi, cv2.DIST_L2, 3)
    for level in (3.0, 5.0, 8.0, 12.0):
        n, labels = cv2.connectedComponents(cv2.compare(dist, level, cv2.CMP_GT))
        if 3 <= n <= 4:
            yield labels.astype(np.uint8)


def _evaluate(subs: list[Blob], view: FrameView, may_split: bool) -> list[Piece] | None:
    """Each piece with its best kind (:func:`_judge`)."""
    geo = view.geo
    fits = fit_kinds(subs, geo, view.settings.min_kind_confidence)
    pieces = [(sub, kind, conf, res, fit, geo.area_mm2(sub))
              for sub, (kind, conf, fit, res) in zip(subs, fits, strict=True)]
    return _judge(pieces, may_split)


def _judge(pieces: list[Piece], may_split: bool) -> list[Piece] | None:
    """The pieces, or None when one fits no kind and cannot be split further."""
    for p in pieces:
        if p[1] == "unknown" and not (may_split and _may_split(p)):
            return None
    return pieces


def warm_up() -> None:
    """Run every kind of cut (on the outline: cut generation, pieces and fits, in one
    call and, as for a camera with lens distortion, kernel by kernel; on the raster:
    cores, owners, pieces' contours; along the colours), the pieces' centroid and own
    pixels once on a made-up blob of two touching discs, so their first real use loads
    nothing."""
    roi = np.zeros((40, 70), np.uint8)
    cv2.circle(roi, (20, 20), 14, 255, -1)
    cv2.circle(roi, (47, 20), 14, 255, -1)
    for seeds in _core_cuts(roi):
        piece_blobs(*owned_pieces(roi, seeds), (0, 0))
    K = np.array([[600.0, 0, 35.0], [0, 600.0, 20.0], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = (0.0, 0.0, 0.4)
    for dist in (np.zeros(5), np.array([-0.1, 0.0, 0.0, 0.0, 0.0])):
        geo = Geometry(CameraModel(70, 40, K, dist, T), 0.0)
        blob = blobs_of_mask(roi, (0, 0))[0]
        for _ in _polygon_cuts(blob, geo, 0.5, True, [_BUDGET]):
            pass
    blob_centroid(blob)
    fill_within(roi, blob.contour, blob.normals, 0, 0)
    img = np.zeros((40, 70, 3), np.uint8)
    img[:, :34], img[:, 34:] = (200, 60, 50), (60, 80, 200)  # two finishes: a colour cut
    piece_blobs(*owned_pieces(roi, colour_seeds(img, roi, 0, 0)), (0, 0))
