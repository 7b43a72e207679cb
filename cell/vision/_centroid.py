"""The pixel centroid of a blob (a part's region, or a piece of a split blob), compiled
(numba) with the arithmetic of ``cv2.moments`` on its float32 outline and holes.

:func:`cell.vision._blob.px_centroid` takes the polygon moments of the outline and of each
hole (``cv2.moments``: OpenCV's ``contourMoments``, Green's theorem, in imgproc/src/
moments.cpp) and divides; :func:`piece_centroid` does the same sums, term by term in the
same order, so the detector and the split stage (:mod:`cell.vision._split`) get the same
centroid from one call. ``tests/vision/test_centroid.py`` checks it against
:func:`~cell.vision._blob.px_centroid` and ``cv2.moments`` bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cell.vision._blob import Blob, px_centroid

__all__: list[str] = []  # private to cell.vision

_NO_HOLES = np.empty((0, 2))
_NO_ENDS = np.empty(0, np.int64)


@njit(cache=True)
def _moments(p, k0, k1):  # pragma: no cover (compiled)
    """(m00, m10, m01) of ``cv2.moments(p[k0:k1].astype(np.float32))``."""
    a00 = a10 = a01 = 0.0
    xi_1 = np.float64(np.float32(p[k1 - 1, 0]))
    yi_1 = np.float64(np.float32(p[k1 - 1, 1]))
    for i in range(k0, k1):
        xi = np.float64(np.float32(p[i, 0]))
        yi = np.float64(np.float32(p[i, 1]))
        dxy = xi_1 * yi - xi * yi_1
        a00 += dxy
        a10 += dxy * (xi_1 + xi)
        a01 += dxy * (yi_1 + yi)
        xi_1, yi_1 = xi, yi
    if not abs(a00) > 1.1920928955078125e-07:  # FLT_EPSILON: OpenCV leaves them 0
        return 0.0, 0.0, 0.0
    half, sixth = (0.5, 1 / 6) if a00 > 0 else (-0.5, -(1 / 6))
    return a00 * half, a10 * sixth, a01 * sixth


@njit(cache=True)
def _centroid(contour, holes, ends):  # pragma: no cover (compiled)
    """(found, u, v): the centroid of the outline ``contour`` less the holes (hole h's
    points ``holes[ends[h - 1]:ends[h]]``); found False where the area is below 1e-9."""
    a, cx, cy = _moments(contour, 0, contour.shape[0])
    k0 = 0
    for h in range(ends.shape[0]):
        m00, m10, m01 = _moments(holes, k0, ends[h])
        a, cx, cy = a - m00, cx - m10, cy - m01
        k0 = ends[h]
    if abs(a) < 1e-9:
        return False, 0.0, 0.0
    return True, cx / a, cy / a


def blob_centroid(blob: Blob) -> tuple[float, float]:
    """:func:`cell.vision._blob.px_centroid` of a blob, in one compiled call (the
    rare blob of no area is left to it); the blob's own ``centroid_px`` where the window
    pass (:mod:`cell.vision._blobwindows`) computed it the same way."""
    if blob.centroid_px is not None:
        return blob.centroid_px
    if blob.holes:
        holes = np.concatenate([h for h, _ in blob.holes])
        ends = np.cumsum([len(h) for h, _ in blob.holes])
    else:
        holes, ends = _NO_HOLES, _NO_ENDS
    found, u, v = _centroid(blob.contour, holes, ends)
    return (u, v) if found else px_centroid(blob)
