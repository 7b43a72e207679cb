"""Step 3b, kind: which catalogue kind a footprint is, and how well it fits.

Each kind's nominal footprint seen from above (:func:`nominal_descriptors`: length and
width of the minimum-area rectangle, hole fraction, solidity) is compared with the
measured one; the score is the summed squared z-score of the differences (0 = exact),
plus, for the round kinds, a one-sided term on the six-fold facet strength (a hex nut
has sharp flats, a washer or a disc none). The blob is first mapped at mid height
(2.5 mm) and scored against every kind; the best kind (and the runner-up, when close) is
then mapped again with its own edge heights and scored again, keeping the better of the
two scores (:mod:`cell.vision.steps.footprint`; a few nuts' holes and top edges fit better
at mid height); the position is always the kind's own footprint's.

The kind's confidence is its share of the likelihoods exp(-score / 2) over all kinds,
times how well the best kind fits at all: from a score of 4 (a good fit scores 0 to 4)
it halves by the fit limit, 16; below ``min_kind_confidence`` the kind is ``unknown``.
A footprint whose hole fraction is off by more than 3 sigma from its best kind's (a solid
disc of a washer's size has no hole) or whose score passes 16 fits no kind: ``unknown``.
(Gonzalez & Woods, *Digital Image Processing*, ch. 11-12: descriptors and
minimum-distance classification.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cell.catalogue import KINDS, PartKind
from cell.errors import VisionError
from cell.vision._checks import check_range
from cell.vision.steps.footprint import Footprint, TablePlane
from cell.vision.steps.outlines import Outline

__all__ = ["KindFit", "classify_kind", "fit_kind", "holds_another", "nominal_area",
           "nominal_descriptors", "score_kinds"]

_SIGMA_SIZE = 1.2e-3  # m: tolerance on footprint length and width
_SIGMA_HOLE = 0.09  # tolerance on the hole fraction
# ... of a kind without a hole: a hole there is another part's (a nut lying in an L
# bracket's inner corner makes the pair's outline bracket-like, but adds the nut's hole)
_SIGMA_NO_HOLE = 0.035
_SIGMA_SOLIDITY = 0.07
# six-fold facet strength of the round kinds (hex nuts render 0.6-0.9, median 0.8; circles
# mostly under 0.15),
# scored one-sided: sharper flats still make a hex nut, rounder outlines a washer
_FACETS6 = {"hex_nut": 0.65, "washer": 0.05, "disc": 0.05}
_SIGMA_FACETS = 0.12
MAX_FIT = 16.0  # a best score above this fits no kind
_GOOD_FIT = 4.0  # scores up to this are a good fit: the confidence is the share alone
_MAX_HOLE_Z2 = 9.0  # a hole fraction off by more than 3 sigma: not that kind
_MID = 0.0025  # m: the edge height of the classifying footprint
_HOPELESS = 30.0  # a mid-height score above this for every kind: no kind near, not refined
_REFINE_GAP = 4.0  # a runner-up this much worse at mid height is not refined
_SHANK = 0.006  # m: a bolt's shank diameter (M6)
_LEG = 0.012  # m: an L bracket's legs are 12 mm wide


def _outline_area(kind: PartKind) -> float:
    """The area inside a kind's outline seen from above, its hole included (m^2)."""
    return {"hex_nut": 2 * math.sqrt(3) * (kind.width / 2) ** 2,
            "washer": math.pi * (kind.length / 2) ** 2,
            "disc": math.pi * (kind.length / 2) ** 2,
            "l_bracket": kind.length * _LEG + (kind.width - _LEG) * _LEG,
            "bolt": 0.040 * _SHANK + 0.004 * kind.width,  # shank 40 mm long, head 4 mm
            }.get(kind.name, kind.length * kind.width)


def nominal_descriptors(kind: PartKind) -> tuple[float, float, float, float]:
    """(length, width, hole fraction, solidity) of a kind's nominal footprint from above."""
    if kind.name == "bolt":
        # a 6 mm shank 40 mm long and a hex head 10-11.5 mm wide as it rolls; the shank
        # outlines thinner than 6 mm (its lower flanks are dark): solidity 0.64 measured
        return kind.length, 0.011, 0.0, 0.64
    outer = _outline_area(kind)
    solidity = 1.0
    if kind.name == "l_bracket":  # the hull cuts the inner corner off
        solidity = outer / (kind.length * kind.width
                            - 0.5 * (kind.length - _LEG) * (kind.width - _LEG))
    hole = math.pi * (kind.hole / 2) ** 2
    return kind.length, kind.width, hole / outer, solidity


def nominal_area(kind: PartKind) -> float:
    """A kind's net area seen from above (m^2): its outline less its hole."""
    return _outline_area(kind) - math.pi * (kind.hole / 2) ** 2


KIND_NAMES = tuple(KINDS)
_AREA = {name: nominal_area(k) for name, k in KINDS.items()}
# a blob this much larger than its kind may hold a second part: most of the smallest one
_ROOM = 0.6 * min(_AREA.values())
_NOMINAL = np.array([nominal_descriptors(k) for k in KINDS.values()])  # (kinds, 4)
# the facet term per kind: its nominal strength, and the side that counts (-1: only a
# weaker one, the hex nut; +1: only a stronger one; 0: no term)
_FACETS_NOMINAL = np.array([_FACETS6.get(n, 0.0) for n in KINDS])
_FACETS_SIDE = np.array([-1.0 if n == "hex_nut" else float(n in _FACETS6) for n in KINDS])
_SIGMAS = np.array([[_SIGMA_SIZE, _SIGMA_SIZE, _SIGMA_HOLE if n[2] > 0 else _SIGMA_NO_HOLE,
                     _SIGMA_SOLIDITY] for n in _NOMINAL])


def _z2(fp: Footprint) -> np.ndarray:
    """(kinds, 5) squared z-scores: length, width, hole fraction, solidity, facets."""
    d = np.array([fp.length, fp.width, fp.hole_fraction, fp.solidity])
    facets = np.maximum(_FACETS_SIDE * (fp.facets6 - _FACETS_NOMINAL), 0.0)  # (kinds,)
    return np.column_stack([((d - _NOMINAL) / _SIGMAS) ** 2, (facets / _SIGMA_FACETS) ** 2])


def score_kinds(fp: Footprint) -> np.ndarray:
    """The score of ``fp`` against every kind, (kinds,) in the catalogue's order.
    ``fp`` a :class:`Footprint` whose descriptors are finite numbers."""
    if not isinstance(fp, Footprint):
        raise VisionError(f"score_kinds: argument 'fp' must be a Footprint, got {type(fp).__name__}")
    try:
        finite = all(math.isfinite(v) for v in (fp.length, fp.width, fp.hole_fraction,
                                                 fp.solidity, fp.facets6))
    except TypeError:
        finite = False
    if not finite:
        raise VisionError("score_kinds: argument 'fp': its length, width, hole_fraction, "
                          "solidity and facets6 must be finite numbers")
    return _z2(fp).sum(axis=1)


@dataclass(frozen=True)
class KindFit:
    """The best kind of a blob: ``kind`` (a catalogue kind or ``unknown``), its
    ``confidence`` (0..1), its ``score`` (inf when no kind is near) and the
    ``footprint`` at that kind's edge heights (at mid height when unknown)."""

    kind: str
    confidence: float
    score: float
    footprint: Footprint


def holds_another(fit: KindFit) -> bool:
    """Whether a blob that fits its kind holds more area than the kind by most of the
    smallest part's (0.6 of it): a second part may lie in it. A part nested in an L
    bracket's inner corner, or beside a bolt's shank under its head, leaves the outline
    (its rectangle) the kind's own; only the area tells. A single part reads at most
    about 70 mm^2 over its kind's area (an L bracket under raking light), a nut adds
    120 mm^2 or more."""
    return fit.kind in _AREA and fit.footprint.area > _AREA[fit.kind] + _ROOM


def classify_kind(scores: np.ndarray, hole_z2: float = 0.0, *,
                  min_confidence: float = 0.5) -> tuple[str, float]:
    """(kind or ``unknown``, confidence) from the scores (kinds,) and the best kind's
    squared z-score of the hole fraction (see the module docstring); below
    ``min_confidence`` the kind is ``unknown`` (with its confidence).

    ``scores`` (kinds,) finite numbers >= 0, one per catalogue kind; ``hole_z2`` a number
    >= 0 (inf: no hole fits); ``min_confidence`` in [0, 1]."""
    try:
        arr = np.asarray(scores, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.full(1, np.nan)
    if arr.shape != (len(KIND_NAMES),) or not (np.isfinite(arr).all() and arr.min() >= 0):
        raise VisionError(f"classify_kind: argument 'scores': expected {len(KIND_NAMES)} finite "
                          f"numbers >= 0 (one per kind: {', '.join(KIND_NAMES)}), got "
                          f"{getattr(scores, 'shape', type(scores).__name__)}")
    check_range("hole_z2", hole_z2, 0.0, math.inf)
    check_range("min_confidence", min_confidence, 0.0, 1.0)
    return _classify(arr, float(hole_z2), min_confidence=float(min_confidence))


def _classify(scores: np.ndarray, hole_z2: float, *, min_confidence: float) -> tuple[str, float]:
    """:func:`classify_kind` of checked arguments (the detector's per-blob call)."""
    best = int(np.argmin(scores))
    s = float(scores[best])
    if s > MAX_FIT or hole_z2 > _MAX_HOLE_Z2:
        return "unknown", 0.0
    share = 1.0 / float(np.exp(-(scores - s) / 2).sum())
    confidence = share * 2.0 ** (-max(s - _GOOD_FIT, 0.0) / (MAX_FIT - _GOOD_FIT))
    return (KIND_NAMES[best] if confidence >= min_confidence else "unknown"), confidence


def _edge_heights(kind: str, mid: Footprint) -> tuple[np.ndarray | float, np.ndarray | float]:
    """Heights (m) of a kind's silhouette edges facing the nadir and away from it; a
    bolt's per outline point, from its mid-height footprint: its head (the wider end)
    stands from the belt to its height, its lying shank from the belt to its diameter."""
    h = KINDS[kind].height
    if kind != "bolt":
        return 0.0, h
    axis = np.array([math.cos(mid.rect_angle), math.sin(mid.rect_angle)])
    rel = mid.outline - mid.centroid
    s, t = rel @ axis, np.abs(rel @ np.array([-axis[1], axis[0]]))
    wide_max, wide_min = t[s > s.max() - 0.004].max(), t[s < s.min() + 0.004].max()
    head = s > s.max() - 0.005 if wide_max > wide_min else s < s.min() + 0.005
    return np.zeros(len(head)), np.where(head, h, _SHANK)


def fit_kind(blob: Outline, plane: TablePlane, *, min_confidence: float = 0.5) -> KindFit:
    """The :class:`KindFit` of a blob (see the module docstring): ``blob`` an
    :class:`~cell.vision.steps.outlines.Outline`, ``plane`` a
    :class:`~cell.vision.steps.footprint.TablePlane`, ``min_confidence`` in [0, 1]."""
    if not isinstance(blob, Outline):
        raise VisionError(f"fit_kind: argument 'blob' must be an Outline, got {type(blob).__name__}")
    if not isinstance(plane, TablePlane):
        raise VisionError(f"fit_kind: argument 'plane' must be a TablePlane, got "
                          f"{type(plane).__name__}")
    check_range("min_confidence", min_confidence, 0.0, 1.0)
    rays = plane.rays_of(blob)
    mid = plane.footprint(rays, (_MID, _MID))
    scores = _z2(mid).sum(axis=1)
    order = np.argsort(scores)
    if scores[order[0]] > _HOPELESS:
        return KindFit("unknown", 0.0, math.inf, mid)
    footprints, z2, rough = {}, _z2(mid), scores.copy()
    for k in order[:2]:
        if rough[k] > rough[order[0]] + _REFINE_GAP:
            break
        footprints[k] = fp = plane.footprint(rays, _edge_heights(KIND_NAMES[k], mid))
        refined = _z2(fp)[k]
        if refined.sum() < scores[k]:  # (else mid height fits it better: keep its score)
            z2[k] = refined
            scores[k] = z2[k].sum()
    best = int(np.argmin(scores))
    kind, confidence = _classify(scores, float(z2[best, 2]), min_confidence=min_confidence)
    fp = footprints.get(best, mid) if kind != "unknown" else mid
    return KindFit(kind, confidence, float(scores[best]), fp)
