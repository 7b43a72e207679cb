"""The sort job's decisions, from detections alone: which part next, which bin, when to stop trying.

- **Bin**: a part goes to its material's bin (``metal`` or ``plastic``) when the detector
  is sure of both its kind and its material (``sort.min_kind_confidence``,
  ``sort.min_material_confidence``); to ``reject`` when its kind or material is
  ``unknown`` or either confidence is low.
- **Grasp**: the cup goes where the kind's grasp point is (``cell.robot.pick.GRASP_POINTS``);
  a part of unknown kind is grasped as the catalogue kind nearest to its footprint.
- **Order**: the part furthest downstream within the pick window first (it is the one
  the belt brings out of reach first), except that a part with a taller one so close that
  the cup would land on it waits until that one is gone; partial parts (at the image
  border) wait until they are in full view.
- **Neighbours**: picking a part may move a neighbour (``_disturbs``): the cup's lip
  seals over whatever lies within ``_SEAL_REACH`` of the grasp point (the cup's 9.5 mm
  radius and the vacuum's 2 mm reach) and lifts it along, and a part lifted drags one
  that touches it. Footprints are estimated from the detections alone, generously
  (``_footprint``: the kind's box or circle, of the larger of the nominal and the
  measured size, 1 mm to spare; an ``unknown`` one a circle holding any convex shape of
  its size); heights are not trusted to keep a lower neighbour out of the lip's reach
  (the vacuum lifted a bracket lying 3.5 mm below it). A part whose pick would move a
  candidate that can be picked without moving it waits until that one is gone (the free
  one first). Parts that would move each other (touching ones always) keep their order,
  and the one picked may carry the other along: when any detection it may move goes to
  another bin than it (or to ``reject``), it is a :class:`MixedPick` and goes to
  ``reject``, so both end up counted rejected, never silently in a wrong bin; one left
  behind is then free and sorted as usual. A partial detection (at the image border) is
  a neighbour only where it has a position, which the detector does not give it: a part
  entering the view against a candidate is not seen as its neighbour.
- **Attempts**: each spot on the belt where a pick failed is remembered; after
  ``sort.attempts`` tries the part there is let go (it rides on and is counted ``missed``
  if it leaves the pick zone). A spot is looked for where it was and where the belt (by
  its encoder's travel) would have carried it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from cell.catalogue import KINDS
from cell.jobs.settings import SortSettings
from cell.sim import layout
from cell.vision.detector import Detection

__all__ = ["Attempts", "MixedPick", "choose_bin", "grasp_kind", "pick_candidates"]

_SAME_SPOT = 0.012  # m: a detection this near a failed spot (moved with the belt) is that part
_CUP_REACH = 0.0145  # m: the suction cup's radius (cell.sim.arm, 9.5 mm) and 5 mm to spare
_SEAL_REACH = 0.0115  # m: the cup's radius (9.5 mm) and the vacuum's reach beyond the lip (2 mm)
_SPARE = 0.001  # m: added round every footprint (position error p95 about 0.3 mm)
_NEAR = 0.001  # m: footprints (as estimated) this near may touch: lifting one drags the other
_STEP = 0.0005  # m: between the points of a footprint's outline (_footprint_gap)
# The bounding box's centre from the silhouette centroid (part frame, m) where they differ:
# the L bracket's legs are 12 mm wide, its outer corner at -x, -y (cell.sim.parts).
_BOX_CENTRE = {"l_bracket": (0.004345, 0.004345)}
_BOXES = (1, 2, 4)  # symmetries whose footprint is a box along the yaw; others a circle
_DIAMETER = max(float(np.hypot(k.length, k.width)) for k in KINDS.values())  # m: the largest part


@dataclass(frozen=True)
class MixedPick(Detection):
    """A detection (every field of it) that the cup cannot pick alone: ``mixed_with`` are
    the ``id``s of the detections of the same image it would lift along that go to another
    bin (or to ``reject``). :func:`choose_bin` sends it to ``reject``."""

    mixed_with: tuple[int, ...] = ()


def choose_bin(det: object, settings: SortSettings) -> str:
    """``metal``, ``plastic`` or ``reject`` for detection ``det`` (see the module docstring)."""
    if getattr(det, "mixed_with", ()):
        return "reject"  # the cup may lift parts of another bin along (see pick_candidates)
    sure = (det.kind in KINDS and det.kind_confidence >= settings.min_kind_confidence
            and det.material in ("metal", "plastic")
            and det.material_confidence >= settings.min_material_confidence)
    return det.material if sure and not det.partial else "reject"


def grasp_kind(det: object) -> str:
    """The kind whose grasp the cup uses: the detected one, or for ``unknown`` the kind
    whose nominal footprint (length, width) is nearest the detected size."""
    if det.kind in KINDS:
        return det.kind
    length, width = det.size
    return min(KINDS, key=lambda k: abs(KINDS[k].length - length) + abs(KINDS[k].width - width))


def pick_candidates(detections: list, settings: SortSettings, *, shift: float = 0.0) -> list:
    """The detections the arm may pick, furthest downstream first: whole parts (not
    partial, with a position) whose position, moved ``shift`` metres along the belt (a
    running belt's travel until the pick), lies within ``sort.pick_window`` of the pick
    zone along x and on the belt across it. A part whose pick would disturb a neighbour
    that can be picked without disturbing it comes after that neighbour; one whose pick
    would lift a detection of another bin along is a :class:`MixedPick` (see the module
    docstring)."""
    lo, hi = settings.pick_window
    x0 = float(layout.PICK_ZONE[0])
    out = [d for d in detections
           if d.position is not None and not d.partial
           and x0 + lo <= d.position[0] + shift <= x0 + hi
           and abs(d.position[1] - layout.CONVEYOR_Y) < layout.BELT_WIDTH / 2]
    located = [d for d in detections if d.position is not None]
    disturbs = {id(d): [o for o in located if o is not d and _disturbs(d, o)] for d in out}
    picked = {id(d) for d in out}

    def waits(d: object) -> bool:  # for a candidate it disturbs that can go without disturbing it
        return any(id(o) in picked and not _disturbs(o, d) for o in disturbs[id(d)])

    order = sorted(out, key=lambda d: (waits(d), _under_a_taller(d, out), -d.position[0]))
    return [_mixed(d, disturbs[id(d)], settings) for d in order]


def _mixed(det: object, near: list, settings: SortSettings) -> object:
    """``det``, or a :class:`MixedPick` of it when a detection in ``near`` (those its pick
    would lift along) goes to another bin than it."""
    own = choose_bin(det, settings)
    other = tuple(o.id for o in near if choose_bin(o, settings) != own)
    if not other:
        return det
    return MixedPick(**{f.name: getattr(det, f.name) for f in fields(Detection)}, mixed_with=other)


def _disturbs(det: object, other: object) -> bool:
    """Whether picking ``det`` may move ``other``: the cup, coming down on ``det``'s grasp
    point, would seal over it too (or land on it: ``other``'s footprint lies within
    ``_SEAL_REACH`` of that point), or the two touch (a part lifted drags a neighbour
    wedged against it)."""
    return (_gaps(np.array([_grasp_point(det)]), other)[0] < _SEAL_REACH
            or _footprint_gap(det, other) < _NEAR)


def _grasp_point(det: object) -> tuple[float, float]:
    """Where the cup's centre comes down on ``det`` (x, y m): its kind's grasp point."""
    from cell.robot.pick import GRASP_POINTS

    dx, dy, _ = GRASP_POINTS[grasp_kind(det)]
    c, s = np.cos(det.yaw), np.sin(det.yaw)
    return det.position[0] + c * dx - s * dy, det.position[1] + s * dx + c * dy


@dataclass(frozen=True)
class _Footprint:
    """A footprint as estimated: the box of half sizes ``half_length`` and ``half_width``
    (m) along ``yaw`` (rad) round ``centre`` ((2,) x, y m), grown by ``radius`` (m)."""

    centre: np.ndarray
    yaw: float
    half_length: float
    half_width: float
    radius: float


def _footprint(det: object) -> _Footprint:
    """``det``'s footprint as estimated from the detection, generously. A kind of symmetry
    1, 2 or 4 (L bracket, bolt, square nut) is its bounding box, a round or hexagonal one a circle round its
    corners, each of the larger of the nominal and the measured size; an ``unknown`` one
    a circle of 2/3 of its diagonal round its centroid (a convex shape's centroid divides
    each chord through it at most 2 : 1), a partial one (given a position) a circle of
    the largest part's diagonal; each grown by ``_SPARE``."""
    length, width = det.size
    centre = np.asarray(det.position, dtype=float)
    kind = KINDS.get(det.kind)
    if det.partial:  # only its visible piece measured: any part round a point of it
        return _Footprint(centre, 0.0, 0.0, 0.0, _DIAMETER + _SPARE)
    if kind is None:
        return _Footprint(centre, 0.0, 0.0, 0.0, 2 / 3 * float(np.hypot(length, width)) + _SPARE)
    if kind.symmetry not in _BOXES:
        return _Footprint(centre, 0.0, 0.0, 0.0, max(kind.length, length) / 2 + _SPARE)
    c, s = np.cos(det.yaw), np.sin(det.yaw)
    ox, oy = _BOX_CENTRE.get(det.kind, (0.0, 0.0))
    centre = centre + (c * ox - s * oy, s * ox + c * oy)
    return _Footprint(centre, det.yaw, max(kind.length, length) / 2, max(kind.width, width) / 2,
                      _SPARE)


def _gaps(points: np.ndarray, det: object) -> np.ndarray:
    """The distances (m) from ``points`` ((N, 2) x, y m) to ``det``'s footprint (0 inside)."""
    f = _footprint(det)
    rel = points - f.centre
    c, s = np.cos(f.yaw), np.sin(f.yaw)
    u = np.maximum(0.0, np.abs(c * rel[:, 0] + s * rel[:, 1]) - f.half_length)
    v = np.maximum(0.0, np.abs(-s * rel[:, 0] + c * rel[:, 1]) - f.half_width)
    return np.maximum(0.0, np.hypot(u, v) - f.radius)


def _footprint_gap(det: object, other: object) -> float:
    """The distance (m) between the footprints of ``det`` and ``other`` (0 where they
    overlap): from points 0.5 mm apart round the box of ``det``'s footprint (and its centre)."""
    f = _footprint(det)
    hl, hw = f.half_length, f.half_width
    t = np.linspace(-1.0, 1.0, max(2, int(2 * max(hl, hw) / _STEP) + 1))
    one = np.ones_like(t)
    box = np.concatenate([np.stack(uv, axis=1) for uv in (
        (hl * t, hw * one), (hl * t, -hw * one), (hl * one, hw * t), (-hl * one, hw * t))])
    c, s = np.cos(f.yaw), np.sin(f.yaw)
    points = np.vstack([[0.0, 0.0], box]) @ np.array([[c, s], [-s, c]]) + f.centre
    return max(0.0, float(_gaps(points, other).min()) - f.radius)


def _under_a_taller(det: object, others: list) -> bool:
    """Whether a taller part lies so close to ``det`` that the cup, coming down on
    ``det``, would land on it (then that part is picked first)."""
    height = KINDS[grasp_kind(det)].height
    for o in others:
        if o is det or KINDS[grasp_kind(o)].height <= height:
            continue
        gap = np.hypot(o.position[0] - det.position[0], o.position[1] - det.position[1])
        if gap < _CUP_REACH + max(o.size) / 2:
            return True
    return False


@dataclass
class _Spot:
    """Where a pick failed: (``x``, ``y``) metres, the encoder reading then (m), failures."""

    x: float
    y: float
    encoder: float
    failures: int = 1


@dataclass
class Attempts:
    """Failed picks by spot on the belt; ``limit`` failures at one spot and its part is let go."""

    limit: int
    spots: list[_Spot] = field(default_factory=list)

    def _find(self, position: tuple[float, float], encoder: float) -> _Spot | None:
        for spot in self.spots:
            # the part rode on with the belt, or stayed put (held by the cup, or the belt
            # slid under it): either is the same part
            for x in (spot.x + (encoder - spot.encoder), spot.x):
                if np.hypot(position[0] - x, position[1] - spot.y) < _SAME_SPOT:
                    return spot
        return None

    def failed(self, position: tuple[float, float], encoder: float) -> None:
        """Count a failed pick of the part seen at ``position`` ((x, y) m, world frame) when
        the belt's encoder read ``encoder`` (m)."""
        spot = self._find(position, encoder)
        if spot is None:
            self.spots.append(_Spot(position[0], position[1], encoder))
        else:
            spot.x, spot.y, spot.encoder = position[0], position[1], encoder
            spot.failures += 1

    def given_up(self, position: tuple[float, float], encoder: float) -> bool:
        """Whether the part at ``position`` ((x, y) m, world frame; the encoder then read
        ``encoder``, m) has used up its attempts."""
        spot = self._find(position, encoder)
        return spot is not None and spot.failures >= self.limit
