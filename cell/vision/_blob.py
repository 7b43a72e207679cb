"""A part's outline in the image, as the detector carries it between its steps.

A ``Blob`` holds one outer contour with its holes, each shifted half a pixel outward from
the centres of its edge pixels (``cv2.findContours`` traces those centres; the region's
edge lies half a pixel further out) with the region's outward unit normals, the bounding
box, whether the blob touches the image border, and the part's own pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

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


def make_blob(pts: np.ndarray, contours, hier, i: int, offset, partial: bool,
              box: tuple[int, int, int, int] | None = None) -> Blob:
    """The blob of outer contour ``i`` of a ``cv2.findContours`` result (RETR_CCOMP), with
    its holes (children of at least 6 points); ``pts`` is that contour as (N, 2) int
    pixels of a crop at ``offset`` (x0, y0) in the frame; ``box`` its bounding box in the
    frame (x, y, w, h) if known."""
    ox, oy = offset
    pts = pts + (ox, oy) if (ox or oy) else pts
    outline, normals = outline_normals(pts, hole=False)
    holes = []
    j = hier[i][2]
    while j != -1:
        hc = contours[j]
        if len(hc) >= 6:
            hc = hc.reshape(-1, 2)
            holes.append(outline_normals(hc + (ox, oy) if (ox or oy) else hc, hole=True))
        j = hier[j][0]
    if box is None:
        bx, by, bw, bh = cv2.boundingRect(contours[i])
        box = (bx + ox, by + oy, bw, bh)
    return Blob(outline, normals, holes, box, partial)


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


def blobs_of_mask(piece: np.ndarray, offset: tuple[int, int]) -> list[Blob]:
    """Blobs (outer contours of at least 8 points and 30 px^2, with holes) of a uint8
    mask crop whose top-left corner is at ``offset`` in the frame."""
    contours, hier = cv2.findContours(piece, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    if hier is None:
        return []
    hier = hier[0]
    return [
        make_blob(c.reshape(-1, 2), contours, hier, i, offset, False)
        for i, c in enumerate(contours)
        if hier[i][3] == -1 and len(c) >= 8 and cv2.contourArea(c) >= 30
    ]


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
