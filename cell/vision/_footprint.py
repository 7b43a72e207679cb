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
from cell.errors import VisionError
from cell.vision._blob import Blob
from cell.vision.kind import (
    KIND_NAMES,
    Footprint,
    classify_kind,
    footprint,
    score_kind,
    score_kinds,
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
        K = camera.K  # as Python floats: the same arithmetic, less overhead per call
        self._fx, self._fy, self._cx, self._cy = (float(K[0, 0]), float(K[1, 1]),
                                                  float(K[0, 2]), float(K[1, 2]))
        self._skew = float(K[0, 1])
        self._R2T = np.ascontiguousarray(self.R[:, :2].T)
        self._R2 = self.R[:, 2].copy()
        nad = camera.K @ (self.R.T @ np.array([0.0, 0.0, -1.0]))
        self.nadir = nad[:2] / nad[2] if nad[2] > 1e-9 else None
        c = np.array([[camera.K[0, 2], camera.K[1, 2]], [camera.K[0, 2] + 1, camera.K[1, 2]]])
        centre = self.o[:2] + (plane_z - self.o[2]) * self._per_drop(self.rays(c))
        self.m_per_px = float(np.linalg.norm(centre[1] - centre[0]))

    def rays(self, pts: np.ndarray) -> np.ndarray:
        """World directions (N, 3) of the rays through pixels (N, 2), lens distortion removed."""
        K, dist = self.camera.K, self.camera.dist
        if self._distorted:  # as cell.vision.geometry.pixel_to_table: iterated to 1e-14
            norm = cv2.undistortPointsIter(
                pts.reshape(-1, 1, 2).astype(np.float64), K, dist, np.eye(3), np.eye(3),
                (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14),
            )
            xy = norm.reshape(-1, 2)
        else:
            xy = np.empty((len(pts), 2))
            y = xy[:, 1]
            np.subtract(pts[:, 1], self._cy, out=y)
            y /= self._fy
            x = xy[:, 0]
            np.subtract(pts[:, 0], self._cx, out=x)
            x -= self._skew * y
            x /= self._fx
        return xy @ self._R2T + self._R2

    @staticmethod
    def _per_drop(d: np.ndarray) -> np.ndarray:
        """(N, 2) world xy travelled per metre of height along rays ``d`` (N, 3)."""
        dz = np.where(np.abs(d[:, 2]) < 1e-12, -1e-12, d[:, 2])
        return d[:, :2] / dz[:, None]

    def prepare(self, blob: Blob) -> None:
        """Rays through the blob's outline and holes, and which points face away from the
        nadir (top edges), computed once per blob (cached on it)."""
        if blob.rays is not None:
            return
        pts = [blob.contour] + [h for h, _ in blob.holes]
        if blob.holes:
            allp = np.concatenate(pts)
            alln = np.concatenate([blob.normals] + [n for _, n in blob.holes])
        else:
            allp, alln = blob.contour, blob.normals
        blob.rays = self._per_drop(self.rays(allp))
        if self.nadir is None:
            blob.away = np.zeros(len(allp), bool)
        else:
            blob.away = np.einsum("ij,ij->i", alln, allp - self.nadir) > 0
        blob.splits = np.cumsum([len(p) for p in pts])

    def plane_points(self, blob: Blob, height: float) -> np.ndarray:
        """World (x, y) (N, 2) of every outline and hole point at ``height`` above the surface."""
        self.prepare(blob)
        return self.o[:2] + (self.plane_z + height - self.o[2]) * blob.rays

    def footprint(self, blob: Blob, lo, hi) -> Footprint | None:
        """The blob's footprint on the table plane for silhouette edges at heights ``lo``
        (edges facing the nadir) and ``hi`` (facing away), metres above the surface:
        scalars, or arrays with one height per outline point (outline, then holes)."""
        self.prepare(blob)
        if np.isscalar(lo) and np.isscalar(hi) and lo == hi:  # one height: no choice
            xy = self.o[:2] + (lo + (self.plane_z - self.o[2])) * blob.rays
        else:
            dz = np.where(blob.away, hi, lo) + (self.plane_z - self.o[2])
            xy = self.o[:2] + dz[:, None] * blob.rays
        cuts = blob.splits
        holes = [xy[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
        try:
            return footprint(xy[: cuts[0]], holes)
        except VisionError:
            return None

    def area_mm2(self, blob: Blob) -> float:
        """The blob's area (outline minus holes) scaled to the table plane at the image
        centre (mm^2)."""
        a = abs(cv2.contourArea(blob.contour.astype(np.float32)))
        a -= sum(abs(cv2.contourArea(h.astype(np.float32))) for h, _ in blob.holes)
        return a * (self.m_per_px * 1e3) ** 2


def fit_kind(blob: Blob, geo: Geometry, min_confidence: float) -> tuple[str, float, float, Fit]:
    """(kind, confidence, fit score, footprint) of the best kind for a blob.

    Classifies on a mid-height footprint, then maps the outline again with the edge
    heights of the best kind (and of the runner-up when it is within ``_REFINE_GAP``) and
    scores those. A blob no kind fits at mid height is ``unknown`` with fit infinity.
    """
    mid = geo.footprint(blob, _MID, _MID)
    if mid is None:
        return "unknown", 0.0, math.inf, Fit(None)
    rough = dict(zip(KIND_NAMES, score_kinds(mid).tolist(), strict=True))
    order = sorted(rough, key=rough.get)[:2]
    if rough[order[0]] > _ROUGH_HOPELESS:  # no kind's footprint can come out fitting
        return "unknown", 0.0, math.inf, Fit(mid)
    if rough[order[1]] > rough[order[0]] + _REFINE_GAP:
        order = order[:1]
    scores, fits = dict(rough), {}
    for k in order:
        lo, hi = edge_heights(k)
        if k == "bolt":
            lo, hi = bolt_heights(blob, geo, mid)
        fp = geo.footprint(blob, lo, hi)
        if fp is not None:
            scores[k] = score_kind(fp, k)
            fits[k] = Fit(fp)
    kind, conf, fit = classify_kind(scores)
    if kind == "unknown" or conf < min_confidence:
        return "unknown", conf, fit, Fit(mid)
    return kind, conf, fit, fits.get(kind, Fit(mid))


def edge_heights(kind: str) -> tuple[float, float]:
    """Heights above the belt (m) of a kind's silhouette edges: facing the nadir, away."""
    h = KINDS[kind].height
    if kind == "bolt":  # a lying cylinder: its silhouette is near its axis height
        return 0.5 * h - 0.0015, 0.5 * h + 0.0015
    return 0.0, h


def bolt_heights(blob: Blob, geo: Geometry, mid: Footprint) -> tuple[np.ndarray, np.ndarray]:
    """Per-point silhouette edge heights of a lying bolt (cell.sim.parts geometry).

    The head (10 mm across flats, its corners 11.5 mm high, 4 mm long) stands like a
    prism from the belt to its top; the 6 mm shank, tilted up towards the head, shows
    its tangent lines between about 1.5 and 8.5 mm. The head is the wider end of the
    mid-height footprint.
    """
    xy = geo.plane_points(blob, _MID)
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
