"""Smoothing of a noisy frame before it is differenced from the belt, compiled.

At every other pixel (the half-scale foreground) or over a window, with borders mirrored:
a k x k box filter, exactly ``cv2.blur`` (rounded to nearest), or, when
``VisionSettings.smooth_sigma`` > 0, a separable Gaussian in integers (weights in 1/256:
it smooths the sensor noise with less blur of the outlines than a box).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cell.vision._segment_kernel import border, max_diff_half

__all__: list[str] = []  # private to cell.vision


def smoothing_taps(k: int, sigma: float) -> np.ndarray:
    """(k,) uint16: the Gaussian weights (``sigma`` px, as ``cv2.getGaussianKernel``) of
    a k-tap smoothing filter in 1/256 (rounded; the centre tap takes the rounding so
    that they sum to 256); empty for sigma 0 (a box filter) or no filter (k = 0)."""
    if sigma <= 0 or k == 0:
        return np.empty(0, np.uint16)
    x = np.arange(k) - (k - 1) / 2
    taps = np.exp(-x * x / (2 * sigma * sigma))
    weights = np.rint(256 * taps / taps.sum()).astype(np.int64)
    weights[k // 2] += 256 - weights.sum()
    return weights.astype(np.uint16)


@njit(cache=True)
def smooth_column(row, t, first, col):  # pragma: no cover (compiled)
    """Add weight ``t`` times uint8 ``row`` to uint16 ``col`` (same length), or set
    ``col`` to it when ``first`` (weights summing to 256: no overflow)."""
    if first:
        for e in range(col.shape[0]):
            col[e] = t * row[e]
    else:
        for e in range(col.shape[0]):
            col[e] += t * row[e]


@njit(cache=True)
def smooth_row(col, taps, acc, out):  # pragma: no cover (compiled)
    """``out`` (n,) uint8: the horizontal pass of the separable filter ``taps`` (k,)
    (in 1/256) over ``col`` (n + 3 (k - 1),) uint16 (its vertical pass, x 256: RGB,
    k // 2 px beyond both ends), rounded to nearest; ``acc`` (n,) uint32 scratch."""
    k, n = taps.shape[0], out.shape[0]
    a = acc[:n]
    first, t = col[:n], taps[0]
    for e in range(n):
        a[e] = t * first[e]
    for j in range(1, k):
        part, t = col[3 * j : 3 * j + n], taps[j]
        for e in range(n):
            a[e] += t * part[e]
    for e in range(n):
        out[e] = (a[e] + 32768) >> 16


@njit(cache=True)
def box_difference(img, bgh, k, taps, dmax):  # pragma: no cover (compiled)
    """``dmax`` (h, w): the largest channel difference between ``bgh`` (h, 3 w) and
    ``img`` (H, 3 W) uint8 (RGB rows) smoothed k x k (borders mirrored) at every other
    pixel: by ``cv2.blur`` (rounded to nearest) when ``taps`` is empty, else by the
    separable filter ``taps`` (in 1/256, :func:`smooth_row`)."""
    hh, n = img.shape
    ww = n // 3
    h = dmax.shape[0]
    r = k // 2
    col = np.empty(3 * (ww + 2 * r), np.uint16)  # column sums, mirrored past the edges
    box = np.empty(3 * ww, np.uint8)
    acc = np.empty(3 * ww, np.uint16)
    if taps.shape[0]:
        colf = np.empty(3 * (ww + 2 * r), np.uint16)
        accf = np.empty(3 * ww, np.uint32)
        inner = colf[3 * r : 3 * (r + ww)]
        for y in range(h):
            for i in range(k):
                smooth_column(img[border(2 * y - r + i, hh)], taps[i], i == 0, inner)
            _mirror_columns(colf, r, ww)
            smooth_row(colf, taps, accf, box)
            max_diff_half(box, bgh[y], dmax[y])
        return
    for y in range(h):
        inner = col[3 * r : 3 * (r + ww)]
        row = img[border(2 * y - r, hh)]
        for e in range(3 * ww):
            inner[e] = row[e]
        for i in range(2 * y - r + 1, 2 * y + r + 1):
            row = img[border(i, hh)]
            for e in range(3 * ww):
                inner[e] += row[e]
        _mirror_columns(col, r, ww)
        box_row(col, k, acc, box)
        max_diff_half(box, bgh[y], dmax[y])


@njit(cache=True)
def box_row(col, k, acc, out):  # pragma: no cover (compiled)
    """``out`` (n,) uint8: the k-wide sums s (3 apart: RGB) of column sums ``col``
    (n + 3 (k - 1),) uint16, over k^2 rounded to nearest: s / k^2 + 1/2 is at least
    1 / 2 k^2 from an integer, far beyond float32 rounding; ``acc`` (n,) uint16 scratch."""
    n = out.shape[0]
    inv = np.float32(1.0 / (k * k))
    first = col[:n]
    for e in range(n):
        acc[e] = first[e]
    for j in range(1, k):
        part = col[3 * j : 3 * j + n]
        for e in range(n):
            acc[e] += part[e]
    half = np.float32(0.5)
    for e in range(n):
        out[e] = np.float32(acc[e]) * inv + half


@njit(cache=True)
def _mirror_columns(col, r, ww):  # pragma: no cover (compiled)
    """Fill the ``r`` columns either side of ``col``'s inner ``ww`` RGB columns with their
    mirror images (``BORDER_REFLECT_101``)."""
    for j in range(r):
        for c in range(3):
            col[3 * j + c] = col[3 * (r + border(j - r, ww)) + c]
            col[3 * (r + ww + j) + c] = col[3 * (r + border(ww + j, ww)) + c]
