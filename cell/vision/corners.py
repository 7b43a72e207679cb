"""Harris corners, written out: structure tensor, response, threshold, non-maximum
suppression.

At each pixel the structure tensor ``M = sum_w [Ix^2, IxIy; IxIy, Iy^2]`` sums the
gradient products over a ``block_size`` window; the Harris response is
``R = det(M) - k trace(M)^2``: large positive at corners (two large eigenvalues),
negative along edges (one), near zero on flat ground.

References: C. Harris and M. Stephens, "A combined corner and edge detector", Alvey
Vision Conference, 1988; Szeliski, *Computer Vision: Algorithms and Applications*,
2nd ed., 7.1.1. :func:`harris_response` reproduces ``cv2.cornerHarris`` (same Sobel
scaling and unnormalised box sum) and is tested against it.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy import ndimage

from cell.errors import VisionError
from cell.vision._checks import (
    MAX_SIZE,
    check_choice,
    check_finite,
    check_gray,
    check_int,
    check_odd,
    check_range,
)

__all__ = ["harris_corners", "harris_response", "non_max_suppression"]

MAX_K = 0.25  # above it det - k trace^2 < 0 for every tensor: no corner can be positive
MAX_SMOOTH = (MAX_SIZE - 1) / 6  # Gaussian sigma whose uint8 kernel (6 sigma + 1) fits MAX_SIZE
MAX_DISTANCE = 2**31 - 1  # pixels: NMS radius (the window is clamped to the image)
F32_MAX = float(np.finfo(np.float32).max)


def harris_response(
    image: np.ndarray, *, block_size: int = 3, ksize: int = 3, k: float = 0.04
) -> np.ndarray:
    """Harris response ``R = det(M) - k trace(M)^2`` per pixel (float32 (H, W)).

    Parameters
    ----------
    image : uint8 or float32 (H, W); float values must be finite.
    block_size : side of the window summing the gradient products (pixels, 2 to 4095).
    ksize : Sobel aperture (1, 3, 5, 7).
    k : Harris constant, typically 0.04-0.06, in [0, 0.25].

    The derivatives are scaled by ``1 / (2**(ksize-1) * block_size * 255)`` for uint8
    input (without the 255 for float), as OpenCV does, so the values equal
    ``cv2.cornerHarris(image, block_size, ksize, k)``. Borders reflect (101).
    """
    image = check_finite("image", check_gray("image", image, dtypes=(np.uint8, np.float32)))
    check_choice("ksize", ksize, (1, 3, 5, 7))
    block_size = check_int("block_size", block_size, 2, MAX_SIZE)
    k = check_range("k", k, 0.0, MAX_K)
    scale = float(2 ** ((ksize if ksize > 0 else 3) - 1) * block_size)
    if image.dtype == np.uint8:
        scale *= 255.0
    scale = 1.0 / scale
    ix = cv2.Sobel(image, cv2.CV_32F, 1, 0, ksize=ksize, scale=scale)
    iy = cv2.Sobel(image, cv2.CV_32F, 0, 1, ksize=ksize, scale=scale)

    def window_sum(a: np.ndarray) -> np.ndarray:
        return cv2.boxFilter(a, -1, (block_size, block_size), normalize=False)

    a, b, c = window_sum(ix * ix), window_sum(ix * iy), window_sum(iy * iy)
    return (a * c - b * b - np.float32(k) * (a + c) ** 2).astype(np.float32)


def _spaced_greedily(points: np.ndarray, min_distance: float) -> np.ndarray:
    """Indices of ``points`` (N, 2) kept by the greedy rule: in the given order, a
    point is kept unless it lies closer than ``min_distance`` (Euclidean, pixels) to a
    point already kept.

    Kept points are filed in square buckets of side ``s = ceil(min_distance)`` keyed
    by ``floor(coordinate) // s`` (integer arithmetic, so exact). Two points closer
    than ``min_distance`` have floors at most ``s`` apart, hence lie in the same or
    neighbouring buckets, so each point is tested against the kept points of the
    3 x 3 buckets around it only; those are ``min_distance`` apart, so a few per
    bucket, and the pass costs O(N) rather than O(N^2).
    """
    side = math.ceil(min_distance)
    cells = (np.floor(points).astype(np.int64) // side).tolist()
    buckets: dict[tuple[int, int], list[tuple[float, float]]] = {}
    kept: list[int] = []
    for i, ((x, y), (cx, cy)) in enumerate(zip(points.tolist(), cells, strict=True)):
        near = (q for bx in (cx - 1, cx, cx + 1) for by in (cy - 1, cy, cy + 1)
                for q in buckets.get((bx, by), ()))
        if all(math.hypot(x - qx, y - qy) >= min_distance for qx, qy in near):
            buckets.setdefault((cx, cy), []).append((x, y))
            kept.append(i)
    return np.asarray(kept, np.int64)


def non_max_suppression(
    response: np.ndarray, *, min_distance: int, threshold: float
) -> np.ndarray:
    """Local maxima of ``response`` above ``threshold``, at least ``min_distance`` apart.

    A pixel is kept when it equals the maximum of its (2 min_distance + 1)^2
    neighbourhood (a separable running maximum, ``scipy.ndimage.maximum_filter``,
    whose cost does not grow with the window); flat plateaus (8-connected kept pixels) collapse
    to their centroid; then, strongest first (equal strengths in OpenCV's label order),
    any kept point closer than ``min_distance`` (pixels) to a stronger one is dropped.
    That last pass files points in a grid of ``min_distance`` buckets, so the whole
    costs O(pixels + points), not O(points^2).

    Parameters
    ----------
    response : float32 (H, W), finite (as from :func:`harris_response`).
    min_distance : pixels, an integer from 1 to 2**31 - 1 (a window wider than the
        image is clamped to it: the same maxima, the cost of the image's size).
    threshold : a finite number (float32 range); only values above it are kept.

    Returns (N, 2) float64 points (x, y), strongest first.
    """
    response = check_finite("response", check_gray("response", response, dtypes=(np.float32,)))
    min_distance = check_int("min_distance", min_distance, 1, MAX_DISTANCE)
    threshold = check_range("threshold", threshold, -F32_MAX, F32_MAX)
    size = 2 * min(min_distance, max(response.shape)) + 1  # larger windows see the same
    peak = ndimage.maximum_filter(response, size=size, mode="nearest")
    keep = (response >= peak) & (response > threshold)
    n, labels, _, cents = cv2.connectedComponentsWithStats(keep.view(np.uint8), connectivity=8)
    if n <= 1:
        return np.zeros((0, 2))
    strength = np.zeros(n, np.float64)
    np.maximum.at(strength, labels[keep], response[keep])
    order = np.argsort(-strength[1:], kind="stable") + 1
    pts = cents[order]
    return pts[_spaced_greedily(pts, min_distance)]


def harris_corners(
    image: np.ndarray,
    *,
    block_size: int = 3,
    ksize: int = 3,
    k: float = 0.04,
    threshold_rel: float = 0.05,
    min_distance: int = 4,
    smooth: float = 0.0,
    refine: str = "subpix",
) -> np.ndarray:
    """Corner points of a grey image: Harris response, threshold, NMS, refinement.

    Parameters
    ----------
    image : uint8 (H, W).
    block_size : odd, 3 to 4095; ``ksize``, ``k``: see :func:`harris_response`.
    threshold_rel : keep responses above this fraction of the image's maximum, in (0, 1).
    min_distance : NMS radius in pixels, 1 to 2**31 - 1.
    smooth : sigma (pixels) of a Gaussian applied before, 0 (none) to 682 (a
        4095-pixel kernel).
    refine : "subpix" moves each point to the sub-pixel position where the local
        gradients are orthogonal to the vectors from it (``cv2.cornerSubPix``, a
        corner's apex, in a window of ``min_distance // 2 + 1`` pixels each side,
        shrunk to ``(min(H, W) - 5) // 2`` on a small image; an image under 7 px
        is not refined); "none" keeps the response peak, which sits about one
        pixel inside a convex corner.

    Returns (N, 2) float64 (x, y) pixels, strongest first, at least ``min_distance``
    apart (after refinement too: a point refined to within it of a stronger one, the
    same corner's other response peak, is dropped).
    """
    image = check_gray("image", image)
    check_choice("refine", refine, ("subpix", "none"))
    if check_range("threshold_rel", threshold_rel, 0.0, 1.0) in (0.0, 1.0):
        raise VisionError(f"argument 'threshold_rel': expected in (0, 1), got {threshold_rel!r}")
    check_odd("block_size", block_size, minimum=3)
    min_distance = check_int("min_distance", min_distance, 1, MAX_DISTANCE)
    smooth = check_range("smooth", smooth, 0.0, MAX_SMOOTH)
    src = cv2.GaussianBlur(image, (0, 0), smooth) if smooth > 0 else image
    r = harris_response(src, block_size=block_size, ksize=ksize, k=k)
    rmax = float(r.max())
    if rmax <= 0:
        return np.zeros((0, 2))
    pts = non_max_suppression(r, min_distance=min_distance, threshold=threshold_rel * rmax)
    # cornerSubPix needs an image of at least 2 win + 5 pixels each way
    win = min(max(2, min_distance // 2 + 1), (min(image.shape) - 5) // 2)
    if refine == "subpix" and len(pts) and win >= 1:
        crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01)
        refined = cv2.cornerSubPix(src, pts.astype(np.float32).reshape(-1, 1, 2).copy(),
                                   (win, win), (-1, -1), crit).reshape(-1, 2)
        # keep the peak where refinement ran away (flat window)
        moved = np.hypot(*(refined - pts).T) > win
        refined[moved] = pts[moved]
        pts = refined.astype(np.float64)
        # two response peaks of one corner (a blurred X-junction has four, 3 px apart)
        # refine onto one apex: keep the stronger
        pts = pts[_spaced_greedily(pts, min_distance)]
    return pts
