"""Step 4, touching parts: cut a blob that fits no kind (or fits one poorly, or holds more
than its kind's area) into pieces that each fit one.

Three kinds of cut are tried, in this order; the first whose pieces fit their kinds well
(a mean score under 6, :mod:`cell.vision.steps.kind`) is taken, else the best of those
tried (the cores are skipped once a straight cut scored under 6.3, the colours once any
cut scored under 9):

1. **Straight cuts between convexity defects** (``cv2.convexHull``,
   ``cv2.convexityDefects``): two convex parts that touch leave a notch on each side of
   the contact (or on one side, when their edges line up); the shortest segments from a
   deep notch to another, or straight across the blob, are tried first (Gonzalez &
   Woods, *Digital Image Processing*, ch. 11: convex deficiency).
2. **Distance-transform cores** (``cv2.distanceTransform``): the blob's pixels deeper
   than a fraction of its largest depth fall apart into one core per part; every pixel
   goes to its nearest core (``cv2.distanceTransform`` to each), the erosion-based
   separation of Gonzalez & Woods, ch. 9-10. Tried when no straight cut fits well.
3. **Colours**: two finishes that touch (a red bracket on a grey one) are two clusters
   in Lab (2-means, ``cv2.kmeans``, L weighted 0.5), taken only when the clusters are
   far apart (Fisher ratio >= 4) and each holds a tenth of the pixels; each cluster's
   regions after a 3x3 opening, those at least a quarter of its largest, seed a piece
   (a streak of light can break a part's face in two). Tried last, on the blob itself.

A piece that fits no kind and is large enough to hold two parts is cut once more (one cut
can so give four pieces); one that fits no kind and is faint (its brightest tenth under
``vision.faint_contrast`` thresholds from the belt,
:func:`~cell.vision.steps.outlines.is_faint`: a grey part at the noise level under dim
light, in fragments) is left out, not reported, and counts in the cut's mean as a piece
scoring the limit 9; such a cut is taken only when no cut whose every piece fits scores
under 9 (else a bright part touching such fragments was lost with them). The search
tries at most 40 cuts per blob. A piece of the best cut that fits its kind but holds
another part's area (a nut nested in an L bracket's inner corner) gets up to 4 cuts of
its own, and a region of the blob that no piece covers (a part touching the others at one
corner only falls away at the cut) is a piece when it fits a kind. The detector sends a
blob here also when it fits a kind poorly (a score of 9 or more: then only a cut that
fits clearly better is taken) or holds another part's area
(:func:`~cell.vision.steps.kind.holds_another`).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from dataclasses import dataclass, replace

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_colour, check_range
from cell.vision.steps.footprint import TablePlane
from cell.vision.steps.foreground import Foreground
from cell.vision.steps.kind import KindFit, fit_kind, holds_another
from cell.vision.steps.material import PartPixels
from cell.vision.steps.outlines import Outline, is_faint, outline_of_mask

__all__ = ["Piece", "split_blob"]

_GOOD = 6.0  # mean piece score at which a cut is taken without trying more
_ACCEPT = 9.0  # a piece (or a cut, on average) scoring worse fits no kind
_MIN_PAIR_MM2 = 200.0  # two parts cover at least this (mm^2): a smaller piece is not cut
_MIN_PART_MM2 = 60.0  # the smallest part covers about 100 mm^2 (a square nut's ring)
_BUDGET = 40  # cuts tried per blob, both depths together (a nested piece's _FEW aside)
_MAX_DEPTH = 1  # a piece that fits no kind is cut once more: a cut gives up to four pieces
_FEW = 4  # cuts tried on a piece that fits its kind but may hold another (_nested)
_MIN_WIDTH = 0.0095  # m: a blob narrower than this holds no part (the narrowest is 11 mm)
_BETTER, _POOR = 2.0, 13.0  # a blob fitting one kind poorly is cut if the cut fits better
_MIN_NOTCH_PX = 2.0  # a convexity defect at least this deep (px) may be a contact
_CORE_LEVELS = (0.5, 0.65, 0.8)  # fractions of the largest depth that make the cores
_SEED_SHARE = 0.25  # a colour's regions this large against its largest seed a piece too
_SQUARE = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class Piece:
    """One part cut out of a blob: its ``blob`` (outline and pixels), its ``fit``, and
    ``cut``, (N,) bool over its outline's points: those on a cut (not an edge of the part:
    the yaw leaves them out); None when no straight cut bounds it."""

    blob: Outline
    fit: KindFit
    cut: np.ndarray | None = None


@dataclass
class _Search:
    plane: TablePlane
    foreground: Foreground
    min_confidence: float
    faint_contrast: float
    budget: int = _BUDGET

    @property
    def frame(self) -> tuple[int, int]:
        """(width, height) of the frame (px)."""
        return self.foreground.mask.shape[1], self.foreground.mask.shape[0]


def split_blob(blob: Outline, whole: KindFit, *, foreground: Foreground, plane: TablePlane,
               min_confidence: float = 0.5, faint_contrast: float = 0.0) -> list[Piece]:
    """The pieces of a blob of touching parts, or [] when no cut gives pieces that fit
    (see the module docstring). ``whole`` is the blob's own fit; ``foreground`` the
    frame's :class:`~cell.vision.steps.foreground.Foreground` (its ``image``, uint8 RGB,
    for the colour cut; its ``difference`` and ``threshold`` tell a faint piece);
    ``min_confidence`` as :func:`~cell.vision.steps.kind.fit_kind`'s; ``faint_contrast``
    as ``vision.faint_contrast`` (0: no piece is faint)."""
    if not isinstance(foreground, Foreground):
        raise VisionError(f"split_blob: argument 'foreground' must be a Foreground, got "
                          f"{type(foreground).__name__}")
    check_colour("image", foreground.image)
    faint_contrast = check_range("faint_contrast", faint_contrast, 0.0, 20.0)
    if plane.area_mm2(blob) <= _MIN_PAIR_MM2 or whole.footprint.width < _MIN_WIDTH:
        return []  # too small for two parts, or narrower than any part: a strip
    limit = _ACCEPT
    if whole.kind != "unknown":  # it fits a kind, poorly: a clearly better cut wins
        limit = max(_ACCEPT, min(whole.score - _BETTER, _POOR))
    search = _Search(plane, foreground, min_confidence, faint_contrast)
    cost, pieces = _best_cut(blob.pixels, search, depth=0)
    if cost >= limit:
        return []
    pieces = [q for p in pieces for q in _nested(p, search)]
    return pieces + _left_out(blob.pixels, pieces, search)


def _left_out(pixels: PartPixels, pieces: list[Piece], search: _Search) -> list[Piece]:
    """Parts a cut left out: the blob's regions that no piece covers (after a 3x3 opening:
    not the cut's line), each kept when it fits a kind. A third part that touches the
    others at a corner only falls apart from them at the cut (4-connected pieces), and a
    cut keeps its two largest pieces."""
    rest = pixels.mask.copy()
    for p in pieces:
        own = p.blob.pixels
        h, w = own.mask.shape
        y, x = own.y0 - pixels.y0, own.x0 - pixels.x0
        rest[y:y + h, x:x + w] &= ~own.mask
    rest = cv2.morphologyEx(rest, cv2.MORPH_OPEN, _SQUARE)
    out = []
    for blob in outline_of_mask(rest, pixels.x0, pixels.y0, frame=search.frame):
        if search.plane.area_mm2(blob) < _MIN_PART_MM2:
            continue
        fit = fit_kind(blob, search.plane, min_confidence=search.min_confidence)
        if fit.kind != "unknown" and fit.score < _ACCEPT and not blob.partial:
            out.append(Piece(blob, fit))
    return out


def _best_cut(pixels: PartPixels, search: _Search, *, depth: int) -> tuple[float, list[Piece]]:
    """(mean score, pieces) of the best cut of a blob's pixels, (inf, []) if none. A cut
    that leaves a faint piece out is taken only when no cut whose every piece fits scores
    under the limit 9; such cuts neither end the search nor skip the cuts after them."""
    best: tuple[float, list[Piece]] = (math.inf, [])  # every piece fits
    fallback: tuple[float, list[Piece]] = (math.inf, [])  # faint pieces left out
    for kind_of_cut, candidate in _candidates(pixels, search, depth):
        if search.budget <= 0:
            break
        if kind_of_cut == "cores" and best[0] < 0.7 * _ACCEPT:
            continue  # a straight cut already fits well
        if kind_of_cut == "colour" and best[0] < _ACCEPT:
            break
        search.budget -= 1
        pieces, faint = _evaluate(candidate, pixels, search, depth)
        scores = [p.fit.score for p in pieces if not p.blob.partial]
        if not scores:  # (a piece at the image border has no kind to fit)
            continue
        cost = (sum(scores) + faint * _ACCEPT) / (len(scores) + faint)
        if faint:
            if cost < fallback[0]:
                fallback = (cost, pieces)
        elif cost < best[0]:
            best = (cost, pieces)
            if cost < _GOOD:
                break
    return best if best[0] < _ACCEPT or fallback[0] >= best[0] else fallback


def _evaluate(candidate: list[tuple[np.ndarray, tuple | None]], pixels: PartPixels,
              search: _Search, depth: int) -> tuple[list[Piece], int]:
    """The pieces of one cut, each fitted (and cut again when it fits no kind and may
    hold two parts), and how many faint pieces that fit no kind it left out; ([], 0) when
    a piece that is not faint fits no kind, or when every piece is left out."""
    out, faint = [], 0
    for mask, segment in candidate:
        found = outline_of_mask(mask, pixels.x0, pixels.y0, frame=search.frame)
        if not found:
            return [], 0
        blob = max(found, key=lambda b: b.area)
        fit = fit_kind(blob, search.plane, min_confidence=search.min_confidence)
        if blob.partial:  # cut by the image border: a part, of no kind
            out.append(Piece(blob, fit))
            continue
        if fit.kind == "unknown" or fit.score >= _ACCEPT:
            if is_faint(blob.pixels, search.foreground, search.faint_contrast):
                faint += 1  # fragments of a part at the noise level: no shape to fit
                continue
            if depth >= _MAX_DEPTH or search.plane.area_mm2(blob) <= _MIN_PAIR_MM2:
                return [], 0
            cost, sub = _best_cut(blob.pixels, search, depth=depth + 1)
            if cost >= _ACCEPT:
                return [], 0
            out += [_mark_cut(q, segment, (pixels.x0, pixels.y0)) for q in sub]  # this cut too
            continue
        out.append(_mark_cut(Piece(blob, fit), segment, (pixels.x0, pixels.y0)))
    return (out, faint) if out else ([], 0)


def _nested(piece: Piece, search: _Search) -> list[Piece]:
    """A piece of the best cut that fits its kind but holds more area
    (:func:`~cell.vision.steps.kind.holds_another`) cut in two when one of the first few
    cuts gives pieces that fit (a part nested in it shows at the first notches); else
    the piece itself."""
    if piece.blob.partial or not holds_another(piece.fit):
        return [piece]
    cost, pieces = _best_cut(piece.blob.pixels, replace(search, budget=_FEW), depth=_MAX_DEPTH)
    return pieces if cost < _ACCEPT else [piece]


def _candidates(pixels: PartPixels, search: _Search, depth: int
                ) -> Iterator[tuple[str, list[tuple[np.ndarray, tuple | None]]]]:
    """Candidate cuts, lazily, in the order they are tried: (kind of cut, pieces), each
    piece a mask in the blob's box with the cut segment that bounds it (or None)."""
    mask = pixels.mask
    for a, b in _notch_cuts(mask):
        pieces = _cut_along(mask, a, b)
        if pieces:
            yield "straight", pieces
    dist = cv2.distanceTransform(mask, cv2.DIST_L2, 5)
    for level in _CORE_LEVELS:
        cores = np.uint8(dist > level * dist.max())
        n, labels = cv2.connectedComponents(cores)
        if n > 2:
            yield "cores", _nearest(mask, labels)
    if depth == 0:
        seeds = _colour_seeds(pixels, search.foreground.image)
        if seeds is not None:
            yield "colour", _nearest(mask, seeds)


def _notch_cuts(mask: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Straight cuts (a, b) (px, in the mask's box) from the deepest point of each deep
    convexity defect to another such point, or to the nearest point of the outline across
    the blob (a contact with a notch on one side only), shortest first, each once; each runs inside
    the blob (its midpoint does)."""
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    c = max(contours, key=len)
    if len(c) < 8:
        return []
    hull = cv2.convexHull(c, returnPoints=False)
    try:
        defects = cv2.convexityDefects(c, np.sort(hull, axis=0))
    except cv2.error:  # a self-touching contour
        return []
    if defects is None:
        return []
    deep = defects[defects[:, 0, 3] >= 256 * _MIN_NOTCH_PX, 0]
    deep = deep[np.argsort(-deep[:, 3])][:6]
    pts = c[:, 0].astype(np.float64)
    cuts = []
    for i, fi in enumerate(deep[:, 2]):
        for fj in deep[i + 1:, 2]:
            cuts.append((pts[fi], pts[fj]))
        apart = np.abs((np.arange(len(pts)) - fi + len(pts) // 2) % len(pts) - len(pts) // 2)
        dist = np.where(apart > len(pts) // 8, np.linalg.norm(pts - pts[fi], axis=1), np.inf)
        cuts.append((pts[fi], pts[int(np.argmin(dist))]))
    inside = [(a, b) for a, b in cuts if mask[int(round((a[1] + b[1]) / 2)), int(round((a[0] + b[0]) / 2))]]
    unique = {frozenset((tuple(a), tuple(b))): (a, b) for a, b in inside}  # (a-b is b-a)
    return sorted(unique.values(), key=lambda ab: float(np.linalg.norm(ab[0] - ab[1])))


def _cut_along(mask: np.ndarray, a: np.ndarray, b: np.ndarray
               ) -> list[tuple[np.ndarray, tuple]] | None:
    """The two largest pieces of ``mask`` either side of the segment a-b, each with the
    segment's pixels that touch it, or None when the segment does not cut the blob."""
    cut = mask.copy()
    cv2.line(cut, tuple(int(round(v)) for v in a), tuple(int(round(v)) for v in b), 0, 1,
             cv2.LINE_8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(cut, connectivity=4)
    if n < 3:
        return None
    line = np.uint8((mask > 0) & (cut == 0)) * np.uint8(255)
    out = []
    for k in np.argsort(-stats[1:, cv2.CC_STAT_AREA])[:2] + 1:
        piece = np.uint8(labels == k) * np.uint8(255)
        out.append((piece | (line & cv2.dilate(piece, _SQUARE)), (a, b)))
    return out


def _nearest(mask: np.ndarray, seeds: np.ndarray) -> list[tuple[np.ndarray, None]]:
    """``mask`` shared out among ``seeds`` (int labels, 0 none, 1.. one per piece): every
    pixel goes to the seed it is nearest to (``cv2.distanceTransform`` to each). Seeds may
    touch: two colours' regions meet where their parts do."""
    ids = [k for k in np.unique(seeds) if k > 0]
    dist = np.stack([cv2.distanceTransform(np.uint8(seeds != k), cv2.DIST_L2, 5) for k in ids])
    nearest = np.argmin(dist, axis=0)
    inside = mask > 0
    return [(np.uint8(inside & (nearest == i)) * np.uint8(255), None) for i in range(len(ids))]


def _colour_seeds(pixels: PartPixels, image: np.ndarray) -> np.ndarray | None:
    """Seeds of the two finishes of a blob (uint8, 1 and 2 on each colour cluster's regions
    at least ``_SEED_SHARE`` of its largest, 0 elsewhere), or None when its colours do not
    form two clusters."""
    mask = pixels.mask
    h, w = mask.shape
    patch = image[pixels.y0:pixels.y0 + h, pixels.x0:pixels.x0 + w]
    inner = cv2.erode(mask, np.ones((3, 3), np.uint8)) > 0
    lab = cv2.cvtColor(patch, cv2.COLOR_RGB2Lab).astype(np.float32) * np.float32([0.5, 1, 1])
    data = lab[inner]
    if len(data) < 40:
        return None
    labels, centres = _two_means(data)
    if min(np.mean(labels == 0), np.mean(labels == 1)) < 0.1:
        return None
    axis = centres[1] - centres[0]
    proj = data @ axis / max(float(np.linalg.norm(axis)), 1e-9)
    a, b = proj[labels == 0], proj[labels == 1]
    if (a.mean() - b.mean()) ** 2 < 4.0 * (a.var() + b.var()):
        return None
    seeds = np.zeros((h, w), np.uint8)
    for k in (0, 1):
        cluster = np.zeros((h, w), np.uint8)
        cluster[inner] = labels == k
        cluster = cv2.morphologyEx(cluster, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
        n, regions, stats, _ = cv2.connectedComponentsWithStats(cluster)
        if n < 2:
            return None
        area = stats[1:, cv2.CC_STAT_AREA]
        keep = np.flatnonzero(area >= _SEED_SHARE * area.max()) + 1
        seeds[np.isin(regions, keep)] = k + 1
    return seeds


def _two_means(data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Labels (N,) and centres (2, D) of ``data`` (N, D) float32 in two clusters
    (``cv2.kmeans``, a k-means++ start). The start draws from OpenCV's generator, one per
    thread: it is seeded in a thread of its own, so the same frame gives the same cut and
    the caller's generator is left as it was. A start without chance (the two sides of the
    colours' principal axis) was tried: 327-329 missed parts against 319 on 8 sets."""
    out: dict = {}

    def run() -> None:
        try:
            cv2.setRNGSeed(0)
            criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 20, 0.1)
            out["result"] = cv2.kmeans(data, 2, None, criteria, 1, cv2.KMEANS_PP_CENTERS)
        except BaseException as exc:  # raised again in the caller's thread
            out["error"] = exc

    worker = threading.Thread(target=run, name="cell-kmeans")
    worker.start()
    worker.join()
    if "error" in out:
        raise out["error"]
    _, labels, centres = out["result"]
    return labels.ravel(), centres


def _mark_cut(piece: Piece, segment: tuple | None, origin: tuple[int, int]) -> Piece:
    """The piece with its outline's points on the cut ``segment`` (within 1.5 px; in the
    box whose corner is ``origin``) marked in its ``cut``, besides those of an earlier one."""
    if segment is None:
        return piece
    p = piece.blob.outer.points - origin
    a, b = segment
    ab = b - a
    t = np.clip(((p - a) @ ab) / max(float(ab @ ab), 1e-9), 0, 1)
    on = np.linalg.norm(p - (a + t[:, None] * ab), axis=1) < 1.5
    if piece.cut is not None:
        on |= piece.cut
    if not on.any() or on.all():
        return piece
    return replace(piece, cut=on)
