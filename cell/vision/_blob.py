"""A part's outline in the image, as the detector carries it between its steps.

A ``Blob`` holds one outer contour with its holes, each shifted half a pixel outward from
the centres of its edge pixels (``cv2.findContours`` traces those centres; the region's
edge lies half a pixel further out) with the region's outward unit normals, the bounding
box, whether the blob touches the image border, and the part's own pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numba import njit

__all__: list[str] = []  # private to cell.vision



@dataclass
class Blob:
    contour: np.ndarray  # (N, 2) float pixel outline, outward-shifted by half a pixel
    normals: np.ndarray  # (N, 2) outward unit normals of the part region
    holes: list[tuple[np.ndarray, np.ndarray]]
    mask_box: tuple[int, int, int, int]  # x, y, w, h of the bounding box
    partial: bool
    roi: tuple[int, int, np.ndarray] | None = None  # x0, y0, uint8 mask of the part
    rays: np.ndarray | None = None  # cached by _footprint.Geometry.prepare
    away: np.ndarray | None = None
    splits: np.ndarray | None = None
    area_px: float | None = None  # outline less holes (px^2), once computed
    centroid_px: tuple[float, float] | None = None  # (u, v) of the region, where computed


def outline_normals(pts: np.ndarray, *, hole: bool) -> tuple[np.ndarray, np.ndarray]:
    """A pixel contour (N, 2) shifted half a pixel outward, with the region's outward
    unit normals (the tangent over five points turned by 90 degrees). For a hole contour
    "outward" points into the hole."""
    p = pts.astype(np.float64)
    k = len(p)
    if k < 5:
        t = np.concatenate((p[2:], p[:2])) - np.concatenate((p[-2:], p[:-2]))
    else:  # the same differences p[i + 2] - p[i - 2] (wrapped), without the copies
        t = np.empty_like(p)
        np.subtract(p[4:], p[:-4], out=t[2:-2])
        np.subtract(p[2:4], p[-2:], out=t[:2])
        np.subtract(p[:2], p[-4:-2], out=t[-2:])
    # findContours traces outer boundaries one way and holes the other; the sign of the
    # area says which way this one runs
    flip = cv2.contourArea(pts.astype(np.int32), oriented=True) < 0
    n = np.empty_like(t)  # t turned by -90 degrees (+90 when flipped)
    if flip != hole:
        np.negative(t[:, 1], out=n[:, 0])
        n[:, 1] = t[:, 0]
    else:
        n[:, 0] = t[:, 1]
        np.negative(t[:, 0], out=n[:, 1])
    n /= np.maximum(np.sqrt(np.einsum("ij,ij->i", t, t)), 1e-9)[:, None]
    return p + 0.5 * n, n


@njit(cache=True)
def _normals(pts, meta, out, nrm):  # pragma: no cover (compiled)
    """:func:`outline_normals` of many contours at once: ``out``, ``nrm`` (M, 2) float64
    of ``pts`` (M, 2) int32 pixels, the contours one after another, described by the
    rows of ``meta`` (n, 4) int64: point count (at least 1), whether a hole (0/1), and
    the shift (x, y) each is moved by first. The tangent at point i of a contour of k
    points is p[(i + 2) mod k] - p[(i - 2) mod k]; which way a contour runs
    (findContours traces outer boundaries one way and holes the other) is the sign of
    its area (shoelace, as ``cv2.contourArea(oriented=True)``, exact on pixels)."""
    start = 0
    for c in range(meta.shape[0]):
        k, hole, sx, sy = meta[c, 0], meta[c, 1] != 0, meta[c, 2], meta[c, 3]
        area = 0  # twice the signed area
        for i in range(k):  # (moving a polygon keeps its area)
            j = start + i + 1 if i + 1 < k else start
            area += (np.int64(pts[start + i, 0]) * pts[j, 1]
                     - np.int64(pts[j, 0]) * pts[start + i, 1])
        sign = -1.0 if (area < 0) != hole else 1.0  # t turned by +90 deg where -1
        for i in range(k):
            a, b = i + 2, i - 2  # (i + 2) mod k, (i - 2) mod k
            while a >= k:
                a -= k
            while b < 0:
                b += k
            a, b = start + a, start + b
            tx, ty = float(pts[a, 0] - pts[b, 0]), float(pts[a, 1] - pts[b, 1])
            norm = max(math.sqrt(tx * tx + ty * ty), 1e-9)
            nx, ny = sign * ty / norm, -sign * tx / norm
            nrm[start + i, 0], nrm[start + i, 1] = nx, ny
            out[start + i, 0] = (pts[start + i, 0] + sx) + 0.5 * nx
            out[start + i, 1] = (pts[start + i, 1] + sy) + 0.5 * ny
        start += k


def px_centroid(blob: Blob) -> tuple[float, float]:
    """Pixel centroid (u, v) of the blob's region (outline minus holes), from polygon
    moments (``cv2.moments``)."""
    m = cv2.moments(blob.contour.astype(np.float32))
    a = m["m00"]
    cx, cy = m["m10"], m["m01"]
    for hole, _ in blob.holes:
        mh = cv2.moments(hole.astype(np.float32))
        a, cx, cy = a - mh["m00"], cx - mh["m10"], cy - mh["m01"]
    if abs(a) < 1e-9:
        c = blob.contour.mean(axis=0)
        return float(c[0]), float(c[1])
    return float(cx / a), float(cy / a)
