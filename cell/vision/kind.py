"""Part kind from shape: descriptors of a footprint on the table plane, scored per kind.

A blob's outline (and its holes) is mapped from pixels onto the table plane, so every
descriptor is in metres and free of the perspective scale. For each catalogue kind the
detector maps the outline with that kind's height (see ``cell.vision.detector``), and
:func:`score_kind` compares the resulting footprint with the kind's nominal footprint from
:mod:`cell.catalogue`: length and width of the minimum-area rectangle, the hole fraction
and the solidity (area over convex-hull area). :func:`classify_kind` turns the scores of
all kinds into a label and a confidence. :func:`footprint_yaw` measures the yaw of a
footprint modulo the kind's rotational symmetry.

References: minimum-area rectangle, convex hull and polygon moments as in OpenCV
(``cv2.minAreaRect``, ``cv2.convexHull``, ``cv2.moments``); shape descriptors after
Gonzalez & Woods, *Digital Image Processing*, ch. 11; n-fold orientation from the n-th
circular harmonic of the outline's chord directions (Mardia & Jupp, 2000).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cell.catalogue import KINDS, PartKind
from cell.errors import VisionError
from cell.vision._kindfit import score_rows
from cell.vision._polygons import describe_polygons
from cell.vision._pose import BOLT, HEX_NUT, L_BRACKET, RECTANGLE, SQUARE_NUT, kind_yaw

__all__ = [
    "Footprint",
    "classify_kind",
    "footprint",
    "footprint_yaw",
    "nominal_descriptors",
    "score_kind",
    "score_kinds",
    "score_table",
]

_SIGMA_SIZE = 1.2e-3  # m: tolerance on footprint length and width
_SIGMA_HOLE = 0.09  # tolerance on the hole fraction
# ... of a kind without a hole: a hole there is another part's (a nut lying in an L
# bracket's inner corner makes the pair's outline bracket-like, but adds the nut's hole)
_SIGMA_NO_HOLE = 0.035
_SIGMA_SOLIDITY = 0.07
_MAX_FIT = 16.0  # a summed squared z-score above this fits no kind


@dataclass(frozen=True)
class Footprint:
    """A part's outline on the table plane (metres, world x, y).

    ``outline`` (N, 2) and ``holes`` (each (M, 2)) are closed polygons; ``area`` is the
    net area (outline minus holes, m^2); ``centroid`` (2,) its centroid; ``length`` and
    ``width`` the sides of the minimum-area rectangle (m, length >= width) and
    ``rect_angle`` the direction of its long side (rad); ``hole_fraction`` the holes'
    area over the outline's area; ``solidity`` the outline's area over its hull's area;
    ``facets6`` the strength (0..1) of six-fold flats: the 6th circular harmonic of the
    edge directions of the outline's convex hull (about 0.65-0.75 for a rendered hex nut,
    below 0.2 for a circle).
    """

    outline: np.ndarray
    holes: tuple[np.ndarray, ...]
    area: float
    centroid: np.ndarray
    length: float
    width: float
    rect_angle: float
    hole_fraction: float
    solidity: float
    facets6: float


def footprint(outline: np.ndarray, holes: tuple[np.ndarray, ...] | list[np.ndarray] = ()) -> Footprint:
    """Descriptors of a polygon with holes on the table plane.

    Parameters
    ----------
    outline : (N, 2) float array, the outer boundary in metres (N >= 3).
    holes : polygons (M, 2) in metres inside ``outline`` (fewer than 3 points: ignored).

    Areas and centroids come from polygon moments (Green's theorem, as ``cv2.moments``),
    the rectangle from ``cv2.minAreaRect`` and the hull from ``cv2.convexHull``, all on
    float32 millimetres around the outline's first vertex (float32 keeps its precision);
    see :func:`cell.vision._polygons.describe_polygons`, which does the same for many
    footprints at once.
    """
    outline = np.asarray(outline, dtype=np.float64)
    if outline.ndim != 2 or outline.shape[1] != 2 or outline.shape[0] < 3:
        raise VisionError(f"footprint: outline must be (N>=3, 2), got shape {outline.shape}")
    hole_list = [h for h in (np.asarray(h, dtype=np.float64) for h in holes) if h.shape[0] >= 3]
    polys = [outline, *hole_list]
    starts = np.concatenate(([0], np.cumsum([len(p) for p in polys])))
    d = describe_polygons(np.concatenate(polys), starts, np.zeros(1, np.intp))
    return footprint_of(d.table[0], outline, tuple(hole_list))


def footprint_of(row: np.ndarray, outline: np.ndarray,
                 holes: tuple[np.ndarray, ...]) -> Footprint:
    """The ``Footprint`` of one row of a descriptor table (see
    :class:`~cell.vision._polygons.PolygonSet`) and its polygons."""
    area, _, cx, cy, length, width, angle, hole_fraction, solidity, facets6 = row.tolist()
    return Footprint(
        outline=outline,
        holes=holes,
        area=area,
        centroid=np.array((cx, cy)),
        length=length,
        width=width,
        rect_angle=angle,
        hole_fraction=hole_fraction,
        solidity=solidity,
        facets6=facets6,
    )


# Six-fold facet strength expected of the round kinds (on the bench's tune seeds, hulls of
# outlines at 1.65 px/mm: hex nut medians 0.65-0.73, an exact hexagon 1; circles 0.04-0.09),
# scored one-sided (a hex nut only below, a circle only above); other kinds are told apart
# by size and holes.
_FACETS6 = {"hex_nut": 0.65, "washer": 0.05, "disc": 0.05}
_SIGMA_FACETS = 0.12


def nominal_descriptors(kind: PartKind) -> tuple[float, float, float, float]:
    """(length, width, hole fraction, solidity) of a kind's nominal footprint from above."""
    if kind.name == "hex_nut":
        outer = 2 * math.sqrt(3) * (kind.width / 2) ** 2
    elif kind.name == "square_nut":
        outer = kind.length * kind.width
    elif kind.name in ("washer", "disc"):
        outer = math.pi * (kind.length / 2) ** 2
    else:
        outer = kind.length * kind.width
    hole = math.pi * (kind.hole / 2) ** 2
    solidity = 1.0
    if kind.name == "bolt":
        # Seen from above: a 6 mm shank, 40 mm long, and a hex head 4 mm thick, 10 to 11.5
        # mm wide as it rolls (cell.sim.parts). The hull tapers from head to tip; the shank
        # outlines thinner than 6 mm (its lower flanks are dark), so the solidity measured
        # on outlines (0.64, front/back/dim renders) is below the drawing's 0.75.
        return kind.length, 0.011, 0.0, 0.64
    if kind.name == "l_bracket":
        leg = 0.012  # legs 12 mm wide; the hull cuts the inner corner's triangle off
        area = kind.length * leg + (kind.width - leg) * leg
        hull = kind.length * kind.width - 0.5 * (kind.length - leg) * (kind.width - leg)
        solidity = area / hull
    return kind.length, kind.width, hole / outer if outer else 0.0, solidity


def score_kind(fp: Footprint, kind: str) -> float:
    """Summed squared z-score of a footprint against a kind's nominal descriptors (0 = exact).

    Length and width are compared in metres with a fixed tolerance; hole fraction,
    solidity and (for the round kinds, one-sided) six-fold facet strength as ratios. Lower is better;
    above about 16 the footprint fits no kind.
    """
    if kind not in KINDS:
        raise VisionError(f"score_kind: unknown kind {kind!r}; valid: {', '.join(KINDS)}")
    length, width, hole, solidity = _NOMINAL[kind]
    sigma_hole = _SIGMA_HOLE if hole > 0 else _SIGMA_NO_HOLE
    facets = 0.0
    if kind in _FACETS6:  # one-sided: sharper flats than a render's still make a hex nut
        off = fp.facets6 - _FACETS6[kind]
        facets = (min(off, 0.0) if kind == "hex_nut" else max(off, 0.0)) ** 2 / _SIGMA_FACETS**2
    return (
        ((fp.length - length) / _SIGMA_SIZE) ** 2
        + ((fp.width - width) / _SIGMA_SIZE) ** 2
        + ((fp.hole_fraction - hole) / sigma_hole) ** 2
        + ((fp.solidity - solidity) / _SIGMA_SOLIDITY) ** 2
        + facets
    )


_NOMINAL = {name: nominal_descriptors(k) for name, k in KINDS.items()}
KIND_NAMES = tuple(KINDS)  # the order of :func:`score_kinds`
_TABLE = np.array([_NOMINAL[k] for k in KIND_NAMES])  # (kinds, 4) nominal descriptors
_SIGMAS = np.array([[_SIGMA_SIZE, _SIGMA_SIZE, _SIGMA_HOLE if _NOMINAL[k][2] > 0 else _SIGMA_NO_HOLE,
                     _SIGMA_SOLIDITY] for k in KIND_NAMES])  # (kinds, 4)
_ROUND = np.array([k in _FACETS6 for k in KIND_NAMES])
_ROUND_FACETS = np.array([_FACETS6.get(k, 0.0) for k in KIND_NAMES])
_FACETED = np.array([k == "hex_nut" for k in KIND_NAMES])
# the scoring tables, as the compiled scorers (cell.vision._kindfit) take them
SCORING = (_TABLE, _SIGMAS, _ROUND, _ROUND_FACETS, _FACETED, 1.0 / _SIGMA_FACETS**2)
MAX_FIT = _MAX_FIT


def score_kinds(fp: Footprint) -> np.ndarray:
    """:func:`score_kind` of one footprint against every catalogue kind at once, as a
    (kinds,) array in the order of ``KIND_NAMES`` (the catalogue's)."""
    return score_table(np.array([fp.length]), np.array([fp.width]), np.array([fp.hole_fraction]),
                       np.array([fp.solidity]), np.array([fp.facets6]))[0]


def score_table(length: np.ndarray, width: np.ndarray, hole_fraction: np.ndarray,
                solidity: np.ndarray, facets6: np.ndarray) -> np.ndarray:
    """:func:`score_kind` of n footprints, given as descriptor arrays (n,), against every
    catalogue kind: an (n, kinds) array, kinds in the order of ``KIND_NAMES`` (one
    compiled pass over the table of nominal descriptors)."""
    table = np.zeros((len(length), 10))
    table[:, 4], table[:, 5], table[:, 7] = length, width, hole_fraction
    table[:, 8], table[:, 9] = solidity, facets6
    out = np.empty((len(length), len(KIND_NAMES)))
    score_rows(table, *SCORING, out)
    return out


def classify_kind(scores: dict[str, float]) -> tuple[str, float, float]:
    """Label, confidence and fit from per-kind scores (as returned by :func:`score_kind`).

    The confidence is the best kind's share of the likelihoods ``exp(-score / 2)``; the
    fit is the best score. When the best score exceeds the fit limit, the label is
    ``"unknown"`` with confidence 0.
    """
    if not scores:
        raise VisionError("classify_kind: scores must name at least one kind")
    names = list(scores)
    s = np.array([scores[n] for n in names], dtype=np.float64)
    best = int(np.argmin(s))
    if s[best] > _MAX_FIT:
        return "unknown", 0.0, float(s[best])
    lik = np.exp(-(s - s[best]) / 2)
    return names[best], float(lik[best] / lik.sum()), float(s[best])


YAW_CODES = {"hex_nut": HEX_NUT, "square_nut": SQUARE_NUT, "l_bracket": L_BRACKET, "bolt": BOLT}


def outline_yaw(outline: np.ndarray, centroid_x: float, centroid_y: float, rect_angle: float,
                kind: str, cut: int = 0) -> float:
    """:func:`footprint_yaw` from a footprint's outline (N, 2), centroid and rectangle's
    angle, without building the ``Footprint``."""
    n = KINDS[kind].symmetry if kind in KINDS else 0
    if n == 0:
        return 0.0
    return kind_yaw(np.ascontiguousarray(outline, dtype=np.float64), centroid_x, centroid_y,
                    rect_angle, YAW_CODES.get(kind, RECTANGLE), n, cut)


def footprint_yaw(fp: Footprint, kind: str, *, cut: int = 0) -> float:
    """Yaw of a footprint (rad) for a kind, in [0, 2*pi/symmetry) (0 for continuous symmetry).

    ``cut``: the outline's last ``cut`` points are a straight cut that separated this part
    from one it touched, not an edge: the nuts' flat directions leave them out.

    Hex nut: the flats' direction from the 6th harmonic of the outline's chord directions
    (yaw 0: a corner on +x); square nut: the 4th (yaw 0: flats facing +x); bolt: the long
    axis from second moments (mod pi); L bracket: the long leg's direction seen from the outer corner.

    The n-th circular harmonic of the outline's chord directions (chords of 5 points,
    weighted by length): the flats dominate it, and a chord's direction does not depend on
    how far the outline lies from the centre, so a dilated or slightly perspective-stretched
    outline gives the same angle (directional statistics, Mardia & Jupp, *Directional
    Statistics*, 2000, ch. 3: mean direction of n-fold axial data). The mean is
    re-estimated twice with each chord's weight also scaled by a von Mises kernel
    exp(kappa * (cos(n * (psi - mean)) - 1)), an iteratively reweighted (M-estimator) mean:
    chords across corners and along ragged stretches of a noisy outline, far from the
    flats' direction, count less (kappa: hex nut 1, more gently than the square nut's 2,
    the 6th harmonic's kernel being narrower: tune/held-out dim yaw p95 2.02/2.41 ->
    1.82/1.96 deg). The L bracket: all its edges run at multiples of 90 degrees; the
    rectangle follows a clean outline closely (tune seeds: median 0.05 deg) but turns with
    a bite or a shadow on one side, the 4-fold mean of the chord directions does not: where
    the two disagree by more than 2 degrees, the chords' angle is taken; the centroid sits
    near the outer corner, so the outline reaches farther towards the long leg's tip
    (canonical pose, yaw 0: outer corner at -x, -y, long leg along +x, cell.sim.parts).
    Compiled: :func:`cell.vision._pose.kind_yaw`.
    """
    return outline_yaw(fp.outline, fp.centroid[0], fp.centroid[1], fp.rect_angle, kind, cut)
