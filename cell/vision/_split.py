"""Touching parts: cut a blob that fits no kind into pieces that each fit one.

Candidates: cuts between pairs of deep convexity defects (two convex parts that touch
leave a notch on each side of the contact; the shortest cuts between deep notches are
tried first), then cores of the distance transform at a few depths (erosion-based
separation; Gonzalez & Woods, *Digital Image Processing*, ch. 9-10), every pixel going
to its nearest core. The candidate whose pieces fit their kinds best wins. A piece that
fits no kind is split again (chains of up to four parts) when it is large enough to
hold two parts; one that fits a kind poorly only when no cut's pieces fit well as they
are.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from cell.vision._blob import Blob, blobs_of_mask, px_centroid
from cell.vision._footprint import Fit, fit_kind
from cell.vision._segment import FrameView

__all__: list[str] = []  # private to cell.vision

_GOOD = 4.0  # mean piece fit at which a cut is taken without trying more
_ACCEPT = 9.0  # a piece (or a cut, on average) fitting worse than this fits no kind
# Two parts cover at least this table-plane area (mm^2): twice the smallest nominal
# footprint (a square nut, 119 mm^2) less a margin; a smaller piece is not split again.
_MIN_PAIR_MM2 = 200.0

Piece = tuple[Blob, str, float, Fit, float]  # blob, kind, confidence, footprint, fit


def split_blob(blob: Blob, view: FrameView, depth: int = 0) -> list[tuple[Blob, str, float, Fit]]:
    """Pieces (blob, kind, confidence, footprint) of a blob of touching parts, or [] when
    no cut gives pieces that fit their kinds (mean fit below ``_ACCEPT``)."""
    x, y, bw, bh = blob.mask_box
    ox, oy = x - 1, y - 1
    roi = np.zeros((bh + 2, bw + 2), np.uint8)
    outline = np.round(blob.contour - 0.5 * blob.normals).astype(np.int32)
    cv2.drawContours(roi, [outline], -1, 255, -1, offset=(-ox, -oy))
    filled = roi.copy()  # holes filled: a washer's core is its whole disc
    for hole, hn in blob.holes:
        hp = np.round(hole - 0.5 * hn).astype(np.int32)
        cv2.drawContours(roi, [hp], -1, 0, -1, offset=(-ox, -oy))
    best: list[Piece] = []
    best_cost = math.inf
    deferred: list[list[Piece]] = []  # cuts with a piece that may split further
    for seeds in _cut_candidates(filled):
        pieces = _pieces(roi, seeds, (ox, oy), view, depth < 2)
        if pieces is None:
            continue
        if any(p[1] == "unknown" for p in pieces):  # (each may split: else _pieces is None)
            pieces = _split_further(pieces, view, depth, unknown_only=True)
            if not pieces:
                continue
        cost = sum(p[4] for p in pieces) / len(pieces)
        if cost < best_cost:
            best, best_cost = pieces, cost
        if best_cost < _GOOD:
            break  # every piece fits its kind well: no need to try more cuts
        if depth < 2 and any(p[4] >= _ACCEPT and _may_split(p, view) for p in pieces):
            deferred.append(pieces)
    if best_cost >= _GOOD:
        for pieces in deferred:  # the cuts whose ill-fitting pieces may be parts touching
            out = _split_further(pieces, view, depth)
            if not out:
                continue
            cost = sum(p[4] for p in out) / len(out)
            if cost < best_cost:
                best, best_cost = out, cost
            if best_cost < _GOOD:
                break
    if best_cost >= _ACCEPT:
        return []
    for p in best:
        p[3].centroid_px = px_centroid(p[0])
    return [p[:4] for p in best]


def _may_split(piece: Piece, view: FrameView) -> bool:
    return view.geo.area_mm2(piece[0]) > _MIN_PAIR_MM2


def _split_further(pieces: list[Piece], view: FrameView, depth: int, *,
                   unknown_only: bool = False) -> list[Piece]:
    """The pieces with each unknown one (and unless ``unknown_only`` each ill-fitting
    one) replaced by its own pieces (counted as fitting at ``_GOOD``); [] when an unknown
    piece does not split."""
    out: list[Piece] = []
    for p in pieces:
        if p[1] != "unknown" and (unknown_only or p[4] < _ACCEPT):
            out.append(p)
            continue
        more = split_blob(p[0], view, depth + 1) if _may_split(p, view) else []
        if more:
            out.extend((*m, _GOOD) for m in more)
        elif p[1] == "unknown":
            return []
        else:
            out.append(p)
    return out


def _cut_candidates(roi: np.ndarray):
    """Seed images (uint8, pieces labelled 1..n) for possible splits of ``roi``."""
    contours, _ = cv2.findContours(roi, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if contours:
        c = max(contours, key=len)
        hull = cv2.convexHull(c, returnPoints=False)
        defects = None
        if len(c) >= 5 and hull is not None and len(hull) >= 4:
            try:
                defects = cv2.convexityDefects(c, hull)
            except cv2.error:
                defects = None
        if defects is not None:
            d = defects[:, 0]
            d = d[d[:, 3] >= 2.5 * 256]
            d = d[np.argsort(-d[:, 3], kind="stable")][:6]
            deep = [(float(di) / 256.0, tuple(int(v) for v in c[fi][0])) for _, _, fi, di in d]
            pairs = []
            for i in range(len(deep)):
                for j in range(i + 1, len(deep)):
                    (di, pi), (dj, pj) = deep[i], deep[j]
                    pairs.append((math.dist(pi, pj) / (di + dj), pi, pj))
            pairs.sort()
            for _, pi, pj in pairs[:6]:
                cut = roi.copy()
                cv2.line(cut, pi, pj, 0, 2)
                n, labels = cv2.connectedComponents(cut, connectivity=4)
                if n == 3:
                    yield labels.astype(np.uint8)
    dist = cv2.distanceTransform(roi, cv2.DIST_L2, 3)
    for level in (3.0, 5.0, 8.0, 12.0):
        cores = (dist > level).astype(np.uint8)
        n, labels = cv2.connectedComponents(cores)
        if 3 <= n <= 4:
            yield labels.astype(np.uint8)


def _pieces(roi: np.ndarray, seeds: np.ndarray, offset: tuple[int, int],
            view: FrameView, may_split: bool) -> list[Piece] | None:
    """Every pixel of ``roi`` to its nearest seed, each piece with its best kind; None when
    a piece is a speck, not one region, or fits no kind and cannot be split further."""
    _, near = cv2.distanceTransformWithLabels(
        cv2.compare(seeds, 0, cv2.CMP_EQ), cv2.DIST_L2, 3, labelType=cv2.DIST_LABEL_PIXEL
    )
    seed_labels = seeds[seeds != 0]  # row-major, as DIST_LABEL_PIXEL numbers the seeds
    lookup = np.zeros(max(int(near.max()), len(seed_labels)) + 1, np.uint8)
    lookup[1 : len(seed_labels) + 1] = seed_labels
    owner = cv2.bitwise_and(lookup.take(near), roi)  # roi is 0/255: outside it, nobody
    out: list[Piece] = []
    min_conf = view.settings.min_kind_confidence
    for lab in range(1, int(seeds.max()) + 1):
        piece = cv2.compare(owner, lab, cv2.CMP_EQ)
        if cv2.countNonZero(piece) < 30:
            return None
        sub = blobs_of_mask(piece, offset)
        if len(sub) != 1:
            return None
        sub[0].roi = (offset[0], offset[1], piece)
        kind, conf, fit, res = fit_kind(sub[0], view.geo, min_conf)
        p = (sub[0], kind, conf, res, fit)
        if kind == "unknown" and not (may_split and _may_split(p, view)):
            return None
        out.append(p)
    return out
