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
- **Attempts**: each spot on the belt where a pick failed is remembered; after
  ``sort.attempts`` tries the part there is let go (it rides on and is counted ``missed``
  if it leaves the pick zone). A spot is looked for where it was and where the belt (by
  its encoder's travel) would have carried it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from cell.catalogue import KINDS
from cell.jobs.settings import SortSettings
from cell.sim import layout

__all__ = ["Attempts", "choose_bin", "grasp_kind", "pick_candidates"]

_SAME_SPOT = 0.012  # m: a detection this near a failed spot (moved with the belt) is that part
_CUP_REACH = 0.0145  # m: the suction cup's radius (cell.sim.arm, 9.5 mm) and 5 mm to spare


def choose_bin(det: object, settings: SortSettings) -> str:
    """``metal``, ``plastic`` or ``reject`` for detection ``det`` (see the module docstring)."""
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
    zone along x and on the belt across it."""
    lo, hi = settings.pick_window
    x0 = float(layout.PICK_ZONE[0])
    out = [d for d in detections
           if d.position is not None and not d.partial
           and x0 + lo <= d.position[0] + shift <= x0 + hi
           and abs(d.position[1] - layout.CONVEYOR_Y) < layout.BELT_WIDTH / 2]
    return sorted(out, key=lambda d: (_under_a_taller(d, out), -d.position[0]))


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
        """Count a failed pick of the part seen at ``position`` when the encoder read ``encoder``."""
        spot = self._find(position, encoder)
        if spot is None:
            self.spots.append(_Spot(position[0], position[1], encoder))
        else:
            spot.x, spot.y, spot.encoder = position[0], position[1], encoder
            spot.failures += 1

    def given_up(self, position: tuple[float, float], encoder: float) -> bool:
        """Whether the part at ``position`` has used up its attempts."""
        spot = self._find(position, encoder)
        return spot is not None and spot.failures >= self.limit
