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

from dataclasses import dataclass, field

import cv2
import numpy as np

from cell.camera import CameraModel
from cell.catalogue import KINDS
from cell.vision._blob import Blob
from cell.vision._kindfit import fit_blobs
from cell.vision._polygons import plane_footprints, plane_rays, polygon_area
from cell.vision._pose import bolt_point
from cell.vision.kind import (
    KIND_NAMES,
    MAX_FIT,
    SCORING,
    Footprint,
    footprint_of,
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
    """The footprint of the kind chosen for a blob (mid height if none): its descriptor
    ``row`` (see :class:`~cell.vision._polygons.PolygonSet`), its points ``xy`` (outline,
    then holes, each polygon ending at the cumulative ``ends``); the blob's pixel centroid
    (u, v), and how many of the outline's last points are a cut from a touching part, not
    an edge. The :class:`~cell.vision.kind.Footprint` (``fp``) is built on first use."""

    row: np.ndarray
    xy: np.ndarray
    ends: tuple[int, ...]
    centroid_px: tuple[float, float] = (0.0, 0.0)
    cut: int = 0
    _fp: Footprint | None = field(default=None, repr=False)

    @property
    def outline(self) -> np.ndarray:
        return self.xy[: self.ends[0]]

    @property
    def fp(self) -> Footprint:
        if self._fp is None:
            e = self.ends
            holes = tuple(self.xy[e[j] : e[j + 1]] for j in range(len(e) - 1))
            self._fp = footprint_of(self.row, self.outline, holes)
        return self._fp


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
        centre = self.o[:2] + (plane_z - self.o[2]) * self.plane_rays(c, np.zeros((2, 2)))[0]
        self.m_per_px = float(np.linalg.norm(centre[1] - centre[0]))

    def plane_rays(self, uv: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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
        rays, away = self.plane_rays(allp, alln)
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
        a = blob.area_px
        if a is None:
            a = polygon_area(blob.contour)
            for h, _ in blob.holes:
                a -= polygon_area(h)
            blob.area_px = a
        return a * (self.m_per_px * 1e3) ** 2


class Footprints:
    """The footprints of several blobs on the table plane, with every silhouette edge at
    one ``height`` above the surface (m), described in one pass; :meth:`footprint`
    builds one footprint's :class:`~cell.vision.kind.Footprint`."""

    def __init__(self, geo: Geometry, blobs: list[Blob], height: float) -> None:
        geo.prepare(blobs)
        rays, away, splits = _concatenated(blobs)
        counts = np.array([1 + len(b.holes) for b in blobs])
        h = np.full(len(blobs), height)
        self.xy, self.starts, self.d = plane_footprints(
            rays, away, splits, counts, h, h, geo.o[:2], geo.plane_z - geo.o[2])
        self.holes = counts - 1
        self.outlines = (np.cumsum(counts) - counts).tolist()

    def footprint(self, i: int) -> Footprint:
        """Blob ``i``'s footprint."""
        return self.fit(i).fp

    def fit(self, i: int) -> Fit:
        """Blob ``i``'s footprint as a :class:`Fit`."""
        p, st = self.outlines[i], self.starts
        s = int(st[p])
        ends = tuple(int(st[q]) - s for q in range(p + 1, p + 2 + self.holes[i]))
        return Fit(self.d.table[i], self.xy[s : s + ends[-1]], ends)


def _concatenated(blobs: list[Blob]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rays, away, splits) of prepared blobs, one after the other."""
    if len(blobs) == 1:
        return blobs[0].rays, blobs[0].away, blobs[0].splits
    return (np.concatenate([b.rays for b in blobs]), np.concatenate([b.away for b in blobs]),
            np.concatenate([b.splits for b in blobs]))


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
    geo.prepare(blobs)
    rays, away, splits = _concatenated(blobs)
    counts = np.array([1 + len(b.holes) for b in blobs])
    return fit_gathered(geo, rays, away, np.arange(len(rays)), splits, counts, min_confidence)


def fit_gathered(geo: Geometry, rays: np.ndarray, away: np.ndarray, idx: np.ndarray,
                 splits: np.ndarray, counts: np.ndarray,
                 min_confidence: float) -> list[tuple[str, float, float, Fit]]:
    """:func:`fit_kinds` of footprints whose points are gathered from shared arrays: the
    footprints' points, one after the other, are ``rays[idx]``/``away[idx]`` (per-drop
    rays and top-edge flags, as ``Geometry.prepare`` leaves on a blob), ``splits`` their
    cumulative polygon sizes and ``counts`` how many polygons each has (outline + holes).
    Lets the split stage fit the pieces of a cut without building them."""
    n = len(counts)
    xy = np.empty((len(idx), 2))
    starts = np.empty(len(splits) + 1, np.int64)
    table = np.empty((n, 10))
    kind, conf, fit = np.empty(n, np.int64), np.empty(n), np.empty(n)
    fit_blobs(rays, away, idx, splits, counts, *fit_arguments(geo, min_confidence), xy,
              starts, table, kind, conf, fit)
    out = []
    ends = starts.tolist()
    p = 0
    for i, (k, c, f) in enumerate(zip(kind.tolist(), conf.tolist(), fit.tolist(), strict=True)):
        m = int(counts[i])
        s = ends[p]
        res = Fit(table[i], xy[s : ends[p + m]], tuple(e - s for e in ends[p + 1 : p + m + 1]))
        p += m
        out.append(("unknown" if k < 0 else KIND_NAMES[k], c, f, res))
    return out


def fit_arguments(geo: Geometry, min_confidence: float) -> tuple:
    """The compiled fit's (:func:`cell.vision._kindfit.fit_one`) constant arguments: the
    camera's xy and drop to the plane, the edge heights, the scoring tables, the limits."""
    return (float(geo.o[0]), float(geo.o[1]), float(geo.plane_z - geo.o[2]), _MID, _EDGE_LO,
            _EDGE_HI, _BOLT, KINDS["bolt"].height, *SCORING, MAX_FIT, _ROUGH_HOPELESS,
            _REFINE_GAP, float(min_confidence))


def edge_heights(kind: str) -> tuple[float, float]:
    """Heights above the belt (m) of a kind's silhouette edges: facing the nadir, away."""
    h = KINDS[kind].height
    if kind == "bolt":  # a lying cylinder: its silhouette is near its axis height
        return 0.5 * h - 0.0015, 0.5 * h + 0.0015
    return 0.0, h


def bolt_origin(fp: Footprint) -> np.ndarray:
    """A bolt's reference point: on its axis, 1.4 mm from the middle of its two ends
    towards the head (cell.sim.parts: ends at -20.6 and +23.4 mm). The area centroid
    would move with the head's roll (10 or 11.5 mm wide); the ends do not. The ends are
    the outline's extremes along the rectangle's long side, the head the wider of the
    two 4 mm strips there (compiled: :func:`cell.vision._pose.bolt_point`)."""
    return np.array(bolt_point(np.ascontiguousarray(fp.outline, dtype=np.float64),
                               fp.centroid[0], fp.centroid[1], fp.rect_angle))


_BOLT = KIND_NAMES.index("bolt")
_EDGE_LO = np.array([edge_heights(k)[0] for k in KIND_NAMES])
_EDGE_HI = np.array([edge_heights(k)[1] for k in KIND_NAMES])


def warm_up() -> None:
    """Load (or compile, on the very first run) every compiled kernel of kind fitting,
    footprint description and a bolt's reference point, on a made-up square blob, so a
    detector's first frame is as fast as its others."""
    t = np.linspace(0.0, 2 * np.pi, 40, endpoint=False)
    ring = np.stack([320 + 20 * np.cos(t), 240 + 20 * np.sin(t)], axis=1)
    normals = np.stack([np.cos(t), np.sin(t)], axis=1)
    K = np.array([[600.0, 0, 319.5], [0, 600.0, 239.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[2, 3] = 0.5
    geo = Geometry(CameraModel(640, 480, K, np.zeros(5), T), 0.0)
    for distorted in (False, True):
        geo._distorted = distorted
        blob = Blob(ring, normals, [(0.5 * ring + 160, -normals)], (300, 220, 41, 41), False)
        fit_kinds([blob], geo, 0.5)
        bolt_origin(Footprints(geo, [blob], _MID).footprint(0))
        geo.area_mm2(blob)
