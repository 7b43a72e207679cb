"""Step 3a, footprint: a blob's outline mapped onto the table plane, free of perspective.

A part lying on the belt, seen off-axis, shows a wall: an outline point whose outward
normal faces away from the camera's nadir (the image point straight below the camera)
is a top edge, the others bottom edges. Each outline point's ray (lens distortion
removed, ``cv2.undistortPoints``) meets the plane at its own edge's height, so the
footprint has the part's real size wherever it lies in the image (inverse perspective,
as :func:`cell.vision.geometry.pixel_to_table`; Hartley & Zisserman, *Multiple View
Geometry*, 2nd ed., ch. 8).

Descriptors in metres (Gonzalez & Woods, *Digital Image Processing*, ch. 11): net area
and centroid from polygon moments (``cv2.moments``), the minimum-area rectangle
(``cv2.minAreaRect``), hole fraction, solidity (outline over convex hull,
``cv2.convexHull``) and the six-fold facet strength: the 6th circular harmonic of the
hull's edge directions, weighted by length (Mardia & Jupp, *Directional Statistics*,
2000). They are computed on float32 millimetres around the outline's first point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from cell.camera import CameraModel
from cell.errors import VisionError
from cell.vision.geometry import no_ray
from cell.vision.steps.outlines import Outline

__all__ = ["Footprint", "TablePlane", "describe"]

_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)


@dataclass(frozen=True)
class Footprint:
    """A part's outline on the table plane (metres, world x, y).

    ``outline`` (N, 2) and ``holes`` (each (M, 2)) closed polygons; ``area`` the net
    area (m^2); ``centroid`` (x, y) of that area; ``length``, ``width`` the sides of the
    minimum-area rectangle (length >= width) and ``rect_angle`` its long side's
    direction (rad); ``hole_fraction`` the holes' area over the outline's;
    ``solidity`` the outline's area over its hull's; ``facets6`` 0..1 (a rendered hex
    nut about 0.8, 0.6-0.9; a circle mostly under 0.15).
    """

    outline: np.ndarray
    holes: tuple[np.ndarray, ...]
    area: float
    centroid: tuple[float, float]
    length: float
    width: float
    rect_angle: float
    hole_fraction: float
    solidity: float
    facets6: float


def _moments(poly_mm: np.ndarray) -> tuple[float, float, float]:
    """(area, first moments x, y) of a polygon (float32 mm), orientation ignored."""
    m = cv2.moments(poly_mm)
    sign = 1.0 if m["m00"] >= 0 else -1.0
    return abs(m["m00"]), sign * m["m10"], sign * m["m01"]


def _facets6(hull: np.ndarray) -> float:
    """The 6th circular harmonic's strength of a convex polygon's edge directions."""
    edges = np.diff(np.vstack([hull, hull[:1]]), axis=0).astype(np.float64)
    length = np.hypot(edges[:, 0], edges[:, 1])
    total = length.sum()
    if total <= 0:
        return 0.0
    phase = np.exp(6j * np.arctan2(edges[:, 1], edges[:, 0]))
    return float(abs((length * phase).sum()) / total)


def describe(outline: np.ndarray, holes: tuple[np.ndarray, ...] = ()) -> Footprint:
    """The :class:`Footprint` of a polygon (N >= 3, 2) with holes, in metres.

    ``outline`` (N >= 3, 2) finite numbers enclosing some area (not all on one line);
    ``holes`` a sequence of such (M >= 3, 2) polygons. Anything else is a ``VisionError``
    naming the argument."""
    outline = _polygon("outline", outline)
    scale = float(np.ptp(outline, axis=0).max())
    x, y = (outline - outline.mean(axis=0)).T
    if not abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) > 1e-12 * scale**2:
        raise VisionError("describe: argument 'outline' encloses no area (its points lie on "
                          "one line or at one point)")
    if isinstance(holes, np.ndarray) or not isinstance(holes, tuple | list):
        raise VisionError(f"describe: argument 'holes' must be a tuple of (M, 2) polygons, got "
                          f"{type(holes).__name__}")
    return _describe(outline, tuple(_polygon("holes", h) for h in holes))


def _polygon(name: str, value: object) -> np.ndarray:
    """A polygon (N >= 3, 2) of finite numbers as float64."""
    try:
        p = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        p = np.zeros((0, 0))
    if p.ndim != 2 or p.shape[0] < 3 or p.shape[1] != 2 or not np.isfinite(p).all():
        raise VisionError(f"describe: argument '{name}': expected (N >= 3, 2) finite numbers "
                          f"(metres), got {getattr(value, 'shape', type(value).__name__)}")
    return p


def _describe(outline: np.ndarray, holes: tuple[np.ndarray, ...]) -> Footprint:
    """:func:`describe` of checked polygons (the detector's per-blob call)."""
    origin = outline[0]
    outer = ((outline - origin) * 1e3).astype(np.float32)
    a_out, sx, sy = _moments(outer)
    a_holes = hx = hy = 0.0
    for h in holes:
        a, mx, my = _moments(((h - origin) * 1e3).astype(np.float32))
        a_holes, hx, hy = a_holes + a, hx + mx, hy + my
    net = a_out - a_holes
    if net > 1e-6:
        cx, cy = (sx - hx) / net, (sy - hy) / net
    else:
        cx, cy = (sx / a_out, sy / a_out) if a_out > 1e-9 else outer.mean(axis=0).tolist()
    hull = cv2.convexHull(outer).reshape(-1, 2)
    (_, _), (w, h), angle = cv2.minAreaRect(hull)  # (the rectangle of the hull is the outline's)
    angle = math.radians(angle)
    if w < h:
        w, h, angle = h, w, angle + math.pi / 2
    hull_area = cv2.contourArea(hull)
    return Footprint(
        outline=outline, holes=tuple(holes), area=max(net, 0.0) * 1e-6,
        centroid=(float(origin[0] + cx * 1e-3), float(origin[1] + cy * 1e-3)),
        length=w * 1e-3, width=h * 1e-3, rect_angle=math.atan2(math.sin(angle), math.cos(angle)),
        hole_fraction=a_holes / a_out if a_out > 0 else 0.0,
        solidity=a_out / hull_area if hull_area > 0 else 0.0,
        facets6=_facets6(hull) if len(hull) >= 3 else 0.0,
    )


@dataclass(frozen=True)
class _Rays:
    """Per outline point: ``slope`` (N, 2), the ray's xy change per metre of drop, and
    ``away`` (N,) bool, whether it is a top edge."""

    slope: np.ndarray
    away: np.ndarray


class TablePlane:
    """One camera's pixel rays onto horizontal planes (world z up, metres).

    A camera model below the plane, or whose optical axis does not point down, is a
    ``VisionError`` (its rays would meet the plane behind it: mirrored positions), as is
    one whose rays at the principal point meet the plane at no finite, nonzero spacing (a
    lens distortion that folds the image there, so that ``cv2.undistortPoints`` finds no
    ray). Elsewhere a pixel without a ray gets a non-finite slope, which the steps after
    refuse or leave out.
    """

    def __init__(self, camera: CameraModel, plane_z: float) -> None:
        self.camera = camera
        self.plane_z = plane_z
        self._R = camera.T_world_camera[:3, :3]
        self._o = camera.T_world_camera[:3, 3]
        if not (self._o[2] > plane_z and self._R[2, 2] < 0):
            raise VisionError(f"camera model: at z = {self._o[2]:g} m with its optical axis's z "
                              f"{self._R[2, 2]:+.3g}: it must be above the plane z = {plane_z:g} m "
                              "(vision.plane_z) and look down on it (axis z below 0)")
        nadir = camera.K @ (self._R.T @ np.array([0.0, 0.0, -1.0]))
        self._nadir = nadir[:2] / nadir[2] if nadir[2] > 1e-9 else None
        centre = np.array([[camera.K[0, 2], camera.K[1, 2]], [camera.K[0, 2] + 1, camera.K[1, 2]]])
        xy = self.points(centre, np.zeros(2))
        with np.errstate(invalid="ignore", over="ignore"):  # inf - inf: refused below
            self.m_per_px = float(np.linalg.norm(xy[1] - xy[0]))  # at the image centre
        if not 0 < self.m_per_px < math.inf:
            raise VisionError(f"camera model: its rays at the principal point ({centre[0, 0]:g}, "
                              f"{centre[0, 1]:g}) meet the plane z = {plane_z:g} m {self.m_per_px:g} m "
                              "apart per pixel: it must look at the plane, and its lens distortion "
                              "'dist' must not fold the image there")

    def _slopes(self, uv: np.ndarray) -> np.ndarray:
        """(N, 2) xy change of each pixel's ray per metre it drops."""
        uv = uv.reshape(-1, 1, 2).astype(np.float64)
        if np.any(self.camera.dist):  # iterated to 1e-14, as pixel_to_table
            norm = cv2.undistortPointsIter(uv, self.camera.K, self.camera.dist, None, None,
                                           _UNDISTORT_CRITERIA).reshape(-1, 2)
            # a lens model that folds the image has no ray for some pixels, or two: the
            # iteration then stops anywhere. Such a pixel's point does not map back to it
            norm[no_ray(self.camera, norm, uv.reshape(-1, 2))] = np.nan
        else:
            norm = cv2.undistortPoints(uv, self.camera.K, None).reshape(-1, 2)
        rays = norm @ self._R[:, :2].T + self._R[:, 2]  # R @ (x, y, 1)
        with np.errstate(divide="ignore", invalid="ignore"):  # a ray along the plane: inf
            return rays[:, :2] / -rays[:, 2:3]

    def points(self, uv: np.ndarray, height: np.ndarray | float) -> np.ndarray:
        """Where pixels ``uv`` (N, 2) meet the planes ``height`` (m) above the table."""
        drop = self._o[2] - (self.plane_z + np.asarray(height, dtype=np.float64))
        with np.errstate(invalid="ignore"):  # a ray along the plane (inf) from its height: nan
            return self._o[:2] + self._slopes(uv) * np.reshape(drop, (-1, 1))

    def rays(self, points: np.ndarray, normals: np.ndarray) -> _Rays:
        """The rays of an outline's points (N, 2) and which face away from the nadir."""
        if self._nadir is None:
            away = np.zeros(len(points), bool)
        else:
            away = np.einsum("ij,ij->i", normals, points - self._nadir) > 0
        return _Rays(self._slopes(points), away)

    def rays_of(self, blob: Outline) -> list[_Rays]:
        """The rays of a blob's outer ring and holes, in that order."""
        return [self.rays(r.points, r.normals) for r in (blob.outer, *blob.holes)]

    def footprint(self, rays: list[_Rays], heights: tuple) -> Footprint:
        """The :class:`Footprint` of a blob's rays (:meth:`rays_of`) with its bottom edges
        at ``heights[0]`` and its top edges at ``heights[1]`` above the table (m; scalars,
        or per point of the outer ring, the holes then at their medians)."""
        lo, hi = heights
        polys = []
        for i, r in enumerate(rays):
            if i == 1 and np.ndim(lo):  # (per point of the outer ring: the holes at the medians)
                lo, hi = float(np.median(lo)), float(np.median(hi))
            drop = self._o[2] - self.plane_z - np.where(r.away, hi, lo)
            polys.append(self._o[:2] + r.slope * drop[:, None])
        return _describe(polys[0], tuple(polys[1:]))

    def area_mm2(self, blob: Outline) -> float:
        """The blob's pixel area scaled to the table plane at the image centre (mm^2)."""
        return blob.area * (self.m_per_px * 1e3) ** 2
