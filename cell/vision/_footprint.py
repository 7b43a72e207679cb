"""A blob's outline mapped onto the table plane, and the kind that fits it best.

A prism lying on the belt, seen off-axis, shows a wall: its outline's points whose
outward normal faces away from the camera's nadir are top edges, the others bottom
edges. ``Geometry.footprint`` intersects each outline point's ray with the plane at its
edge's height, so the footprint is free of perspective (inverse perspective through
K and T_world_camera, as :func:`cell.vision.geometry.pixel_to_table`).
:func:`fit_kind` classifies on a footprint at mid height and maps the outline again
only for the best one or two kinds, with their own edge heights.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from cell.camera import CameraModel
from cell.catalogue import KINDS
from cell.vision._blob import Blob
from cell.vision._polygons import plane_footprints, plane_rays
from cell.vision.kind import (
    KIND_NAMES,
    Footprint,
    classify_table,
    footprint_of,
    score_table,
)

__all__: list[str] = []  # private to cell.vision

_MID = 0.0025  # m: the height of the classifying footprint's edges
# A mid-height footprint scoring above this for every kind is not one part: the kind's own
# edge heights change a score by a few units (on the bench, no blob above 25 came out
# fitting), so the refinement is skipped and the blob goes straight to splitting.
_ROUGH_HOPELESS = 30.0
_REFINE_GAP = 12.0  # a runner-up kind this much worse at mid height is not refined


@dataclass
class Fit:
    fp: Footprint | None  # the footprint of the kind chosen (mid height if none)
    centroid_px: tuple[float, float] = (0.0, 0.0)  # the blob's pixel centroid (u, v)


class Geometry:
    """Pixel rays of one camera, intersected with horizontal planes (world z up)."""

    def __init__(self, camera: CameraModel, plane_z: float) -> None:
        self.camera = camera
        self.plane_z = plane_z
        self.R = camera.T_world_camera[:3, :3]
        self.o = camera.T_world_camera[:3, 3]
        self._distorted = bool(np.any(camera.dist))
        nad = camera.K @ (self.R.T @ np.array([0.0, 0.0, -1.0]))
        self.nadir = nad[:2] / nad[2] if nad[2] > 1e-9 else None
        c = np.array([[camera.K[0, 2], camera.K[1, 2]], [camera.K[0, 2] + 1, camera.K[1, 2]]])
        centre = self.o[:2] + (plane_z - self.o[2]) * self._rays(c, np.zeros((2, 2)))[0]
        self.m_per_px = float(np.linalg.norm(centre[1] - centre[0]))

    def _rays(self, uv: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`~cell.vision._polygons.plane_rays` of pixels ``uv`` (N, 2), lens
        distortion removed (as :func:`cell.vision.geometry.pixel_to_table`)."""
        norm = None
        if self._distorted:  # iterated to 1e-14
            norm = cv2.undistortPointsIter(
                uv.reshape(-1, 1, 2).astype(np.float64), self.camera.K, self.camera.dist,
                np.eye(3), np.eye(3), (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14),
            ).reshape(-1, 2)
        return plane_rays(uv, normals, norm, self.camera.K, self.R, self.nadir)

    def prepare(self, blobs: list[Blob]) -> None:
        """Rays through each blob's outline and holes, and which points face away from the
        nadir (top edges), cached on the blob; the blobs not yet prepared are done in one
        pass over all their points."""
        todo = [b for b in blobs if b.rays is None]
        if not todo:
            return
        pts, nrm, sizes = [], [], []
        for b in todo:
            pts.append(b.contour)
            nrm.append(b.normals)
            sizes.append(len(b.contour))
            for h, hn in b.holes:
                pts.append(h)
                nrm.append(hn)
                sizes.append(sizes[-1] + len(h))
        allp = np.concatenate(pts) if len(pts) > 1 else pts[0]
        alln = np.concatenate(nrm) if len(nrm) > 1 else nrm[0]
        rays, away = self._rays(allp, alln)
        k = start = 0
        for b in todo:
            m = 1 + len(b.holes)
            b.splits = np.array(sizes[k : k + m])
            end = start + sizes[k + m - 1]
            b.rays, b.away = rays[start:end], away[start:end]
            k, start = k + m, end

    def area_mm2(self, blob: Blob) -> float:
        """The blob's area (outline minus holes) scaled to the table plane at the image
        centre (mm^2)."""
        a = abs(cv2.contourArea(blob.contour.astype(np.float32)))
        a -= sum(abs(cv2.contourArea(h.astype(np.float32))) for h, _ in blob.holes)
        return a * (self.m_per_px * 1e3) ** 2


class Footprints:
    """The footprints of several blobs on the table plane, described in one pass.

    ``items`` are (blob, lo, hi): the heights above the surface (m) of the silhouette
    edges facing the nadir (``lo``) and facing away (``hi``), scalars or one per outline
    and hole point. ``d`` holds every footprint's descriptors
    (:class:`~cell.vision._polygons.PolygonSet`); ``xy`` the plane points (N, 2);
    :meth:`footprint` builds one footprint's :class:`~cell.vision.kind.Footprint`.
    """

    def __init__(self, geo: Geometry, items: list[tuple[Blob, object, object]]) -> None:
        blobs = [it[0] for it in items]
        geo.prepare(blobs)
        if len(blobs) == 1:
            rays, away, splits = blobs[0].rays, blobs[0].away, blobs[0].splits
        else:
            rays = np.concatenate([b.rays for b in blobs])
            away = np.concatenate([b.away for b in blobs])
            splits = np.concatenate([b.splits for b in blobs])
        counts = np.array([1 + len(b.holes) for b in blobs])
        per_point = any(isinstance(it[1], np.ndarray) for it in items)
        lo = np.array([np.nan if isinstance(it[1], np.ndarray) else it[1] for it in items], float)
        hi = np.array([np.nan if isinstance(it[2], np.ndarray) else it[2] for it in items], float)
        lo_pts = hi_pts = None
        if per_point:  # one height per point for some items (a bolt's)
            lo_pts, hi_pts = (np.concatenate([
                np.broadcast_to(it[c] if isinstance(it[c], np.ndarray) else np.nan, len(it[0].rays))
                for it in items]) for c in (1, 2))
        self.items = items
        self.xy, self.starts, self.d = plane_footprints(
            rays, away, splits, counts, lo, hi, lo_pts, hi_pts, geo.o[:2], geo.plane_z - geo.o[2])
        self.outlines = (np.cumsum(counts) - counts).tolist()
        self._fps: dict[int, Footprint] = {}

    def points(self, i: int) -> np.ndarray:
        """Plane points (N, 2) of item ``i``: outline, then holes."""
        p = self.outlines[i]
        return self.xy[self.starts[p] : self.starts[p + 1 + len(self.items[i][0].holes)]]

    def footprint(self, i: int) -> Footprint:
        """Item ``i``'s footprint (built once)."""
        fp = self._fps.get(i)
        if fp is None:
            p, st = self.outlines[i], self.starts
            holes = tuple(self.xy[st[q] : st[q + 1]]
                          for q in range(p + 1, p + 1 + len(self.items[i][0].holes)))
            fp = self._fps[i] = footprint_of(self.d, i, self.xy[st[p] : st[p + 1]], holes)
        return fp

    def scores(self) -> np.ndarray:
        """(items, kinds) :func:`~cell.vision.kind.score_kind` of every footprint."""
        d = self.d
        return score_table(d.length, d.width, d.hole_fraction, d.solidity, d.facets6)


_KIND_INDEX = {k: i for i, k in enumerate(KIND_NAMES)}


def fit_kinds(blobs: list[Blob], geo: Geometry,
              min_confidence: float) -> list[tuple[str, float, float, Fit]]:
    """(kind, confidence, fit score, footprint) of the best kind for each blob.

    Classifies on mid-height footprints, then maps each outline again with the edge
    heights of its best kind (and of the runner-up when it is within ``_REFINE_GAP``) and
    scores those; all footprints of one step are described in one pass
    (:class:`Footprints`). A blob no kind fits at mid height is ``unknown`` with fit
    infinity.
    """
    if not blobs:
        return []
    mid = Footprints(geo, [(b, _MID, _MID) for b in blobs])
    rough = mid.scores()
    items, which = [], []  # refinement items and their (blob, kind index)
    hopeless = []
    for i, (b, row) in enumerate(zip(blobs, rough.tolist(), strict=True)):
        k0 = min(range(len(row)), key=row.__getitem__)
        hopeless.append(row[k0] > _ROUGH_HOPELESS)
        if hopeless[-1]:
            continue
        k1 = min((k for k in range(len(row)) if k != k0), key=row.__getitem__)
        for k in ((k0, k1) if row[k1] <= row[k0] + _REFINE_GAP else (k0,)):
            if k == _BOLT:
                lo, hi = bolt_heights(mid.points(i), mid.footprint(i))
            else:
                lo, hi = _EDGE_HEIGHTS[k]
            items.append((b, lo, hi))
            which.append((i, k))
    refined = None
    if items:
        refined = Footprints(geo, items)
        rs = refined.scores()
        for j, (i, k) in enumerate(which):
            rough[i, k] = rs[j, k]
    best, conf, fit = classify_table(rough)
    out = []
    for i, (k, c, f) in enumerate(zip(best.tolist(), conf.tolist(), fit.tolist(), strict=True)):
        if hopeless[i]:
            out.append(("unknown", 0.0, math.inf, Fit(mid.footprint(i))))
        elif k < 0 or c < min_confidence:
            out.append(("unknown", c, f, Fit(mid.footprint(i))))
        else:
            j = which.index((i, k)) if (i, k) in which else None
            fp = refined.footprint(j) if j is not None else mid.footprint(i)
            out.append((KIND_NAMES[k], c, f, Fit(fp)))
    return out


def fit_kind(blob: Blob, geo: Geometry, min_confidence: float) -> tuple[str, float, float, Fit]:
    """:func:`fit_kinds` of one blob."""
    return fit_kinds([blob], geo, min_confidence)[0]


def edge_heights(kind: str) -> tuple[float, float]:
    """Heights above the belt (m) of a kind's silhouette edges: facing the nadir, away."""
    h = KINDS[kind].height
    if kind == "bolt":  # a lying cylinder: its silhouette is near its axis height
        return 0.5 * h - 0.0015, 0.5 * h + 0.0015
    return 0.0, h


def bolt_heights(xy: np.ndarray, mid: Footprint) -> tuple[np.ndarray, np.ndarray]:
    """Per-point silhouette edge heights of a lying bolt (cell.sim.parts geometry), from
    its outline's plane points ``xy`` (N, 2) at mid height and that footprint ``mid``.

    The head (10 mm across flats, its corners 11.5 mm high, 4 mm long) stands like a
    prism from the belt to its top; the 6 mm shank, tilted up towards the head, shows
    its tangent lines between about 1.5 and 8.5 mm. The head is the wider end of the
    mid-height footprint.
    """
    axis = np.array([math.cos(mid.rect_angle), math.sin(mid.rect_angle)])
    s = (xy - mid.centroid) @ axis
    t = np.abs((xy - mid.centroid) @ np.array([-axis[1], axis[0]]))
    ends = s.max(), s.min()
    near_max = t[s > ends[0] - 0.004]
    near_min = t[s < ends[1] + 0.004]
    head_at_max = (near_max.max() if near_max.size else 0) > (near_min.max() if near_min.size else 0)
    head = s > ends[0] - 0.005 if head_at_max else s < ends[1] + 0.005
    h = KINDS["bolt"].height
    lo = np.where(head, 0.0, 0.0015)
    hi = np.where(head, h, 0.0085)
    return lo, hi


_BOLT_END_OFFSET = 0.0014  # body origin from the middle of the bolt's ends, towards the head


def bolt_origin(fp: Footprint) -> np.ndarray:
    """A bolt's reference point: on its axis, 1.4 mm from the middle of its two ends
    towards the head (cell.sim.parts: ends at -20.6 and +23.4 mm). The area centroid
    would move with the head's roll (10 or 11.5 mm wide); the ends do not."""
    axis = np.array([math.cos(fp.rect_angle), math.sin(fp.rect_angle)])
    rel = fp.outline - fp.centroid
    s = rel @ axis
    t = rel @ np.array([-axis[1], axis[0]])
    s_max, s_min = float(s.max()), float(s.min())
    w_max = float(np.abs(t[s > s_max - 0.004]).max())
    w_min = float(np.abs(t[s < s_min + 0.004]).max())
    to_head = 1.0 if w_max > w_min else -1.0
    mid = 0.5 * (s_max + s_min) + to_head * _BOLT_END_OFFSET
    return fp.centroid + mid * axis


_BOLT = KIND_NAMES.index("bolt")
_EDGE_HEIGHTS = [edge_heights(k) for k in KIND_NAMES]
