"""Compiled steps of the segmentation (numba), each the exact integer arithmetic of the
OpenCV call it replaces, so the detector's answers do not change:

* the belt's 15x15 median: :mod:`cell.vision._median_kernel`;
* the tables of ``cv2.resize`` (``INTER_LINEAR``, uint8) of the 1/8-scale background by
  8, edges repeated: OpenCV's 11-bit fixed-point weights (:func:`upscale_axis`; applied
  window by window in :mod:`cell.vision._upscale_kernel`);
* ``cv2.absdiff`` and the largest channel, at every other pixel (smoothed first in a noisy
  frame: :mod:`cell.vision._smooth_kernel`); ``cv2.threshold`` (uint8: above the floor of
  the threshold) and the 2x2 ``cv2.morphologyEx`` opening (anchor at the kernel's centre
  (1, 1); the border counts neither for erosion nor dilation);
* histogram medians and MADs, and the per-pixel shadow test of :mod:`cell.vision._segment`.

Images are C-contiguous uint8 so that each kernel compiles once.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

__all__: list[str] = []  # private to cell.vision

_ONE = 2048  # OpenCV's INTER_RESIZE_COEF_SCALE: 11-bit resize weights


@functools.lru_cache(maxsize=16)
def upscale_axis(src: int, dst: int, clamp: bool) -> np.ndarray:
    """(4, dst) int64: the source indices i0, i1 and fixed-point weights w0, w1 of
    ``cv2.resize`` (``INTER_LINEAR``, uint8) by exactly 8 along one axis of ``src``
    pixels, for the first ``dst`` output pixels (the edge repeated beyond 8 src):
    position (d + 0.5) / 8 - 0.5 (float32), weights rounded (x 2048). Columns
    (``clamp``) take the edge pixel alone beyond the first and last centres; rows keep
    their weights and repeat the edge row (OpenCV's resize does both). At scale 8 the
    weights are (2 i + 1) 128 (f = (2 i + 1) / 16) or 0 and 2048: multiples of 128."""
    f = ((np.arange(dst) + 0.5) / 8 - 0.5).astype(np.float32)
    s = np.floor(f).astype(np.int64)
    f = f - s.astype(np.float32)
    if clamp:
        f[s < 0] = 0
        s[s < 0] = 0
        f[s >= src - 1] = 0
        s[s >= src - 1] = src - 1
    table = np.empty((4, dst), np.int64)
    table[0] = np.clip(s, 0, src - 1)
    table[1] = np.clip(s + 1, 0, src - 1)
    table[2] = np.rint((np.float32(1) - f) * np.float32(_ONE))
    table[3] = np.rint(f * np.float32(_ONE))
    assert not (table[2:] % 128).any()  # (what the window background relies on)
    return table


@njit(cache=True)
def border(p, n):  # pragma: no cover (compiled)
    """``cv2.borderInterpolate(p, n, BORDER_REFLECT_101)``: p mirrored into 0..n-1."""
    if n == 1:
        return 0
    while p < 0 or p >= n:
        p = -p if p < 0 else 2 * n - 2 - p
    return p


@njit(cache=True)
def upper_median(hist, n):  # pragma: no cover (compiled)
    """The value of rank n // 2 (0-based) among the n counted in ``hist``."""
    s = 0
    for v in range(hist.shape[0]):
        s += hist[v]
        if s > n // 2:
            return v
    return hist.shape[0] - 1


@njit(cache=True)
def probe_levels(bg):  # pragma: no cover (compiled)
    """(upper median of the largest channel, upper median of largest - smallest) over
    every 3rd pixel of ``bg`` (h, w, 3) uint8."""
    hi = np.zeros(256, np.int64)
    spread = np.zeros(256, np.int64)
    n = 0
    for i in range(0, bg.shape[0], 3):
        for j in range(0, bg.shape[1], 3):
            r, g, b = bg[i, j, 0], bg[i, j, 1], bg[i, j, 2]
            top, low = max(max(r, g), b), min(min(r, g), b)
            top, low = np.int64(top), np.int64(low)
            hi[top] += 1
            spread[top - low] += 1
            n += 1
    return upper_median(hi, n), upper_median(spread, n)


@njit(cache=True)
def difference(img, bgh, sample, dmax):  # pragma: no cover (compiled)
    """``dmax`` (h, w): the largest channel difference of every other pixel of ``img``
    (H, 3 W) uint8 (RGB rows) from ``bgh`` (h, 3 w), on rows 2, 6, 10, ... (those
    :func:`median_mad` reads) when ``sample``, else on all the others."""
    diff = np.empty(bgh.shape[1], np.uint8)
    for y in range(dmax.shape[0]):
        if (y % 4 == 2) == sample:
            max_diff_half(img[2 * y], bgh[y], diff, dmax[y])


@njit(cache=True)
def max_diff(src, bg, diff, out):  # pragma: no cover (compiled)
    """``out`` (w,): the largest channel difference of RGB row ``src`` (3 w,) uint8 from
    ``bg`` (3 w,) uint8; ``diff`` (3 w,) uint8 scratch."""
    for e in range(diff.shape[0]):
        a, b = src[e], bg[e]
        diff[e] = max(a, b) - min(a, b)
    for x in range(out.shape[0]):
        out[x] = max(max(diff[3 * x], diff[3 * x + 1]), diff[3 * x + 2])


@njit(cache=True)
def max_diff_half(src, bg, diff, out):  # pragma: no cover (compiled)
    """``out`` (w,): the largest channel difference of every other pixel of ``src``
    (3 W,) from ``bg`` (3 w,); ``diff`` (3 w,) uint8 scratch."""
    for x in range(out.shape[0]):
        for c in range(3):
            a, b = src[6 * x + c], bg[3 * x + c]
            diff[3 * x + c] = max(a, b) - min(a, b)
    for x in range(out.shape[0]):
        out[x] = max(max(diff[3 * x], diff[3 * x + 1]), diff[3 * x + 2])


@njit(cache=True)
def median_mad(dmax):  # pragma: no cover (compiled)
    """(median, MAD) of every 4th pixel of ``dmax`` (h, w) uint8 from 2, 2, from its
    histogram: the lower median (rank (n - 1) // 2) of the values and of their absolute
    deviations from it."""
    hist = np.zeros(256, np.int64)
    n = 0
    for y in range(2, dmax.shape[0], 4):
        for x in range(2, dmax.shape[1], 4):
            hist[dmax[y, x]] += 1
            n += 1
    med = upper_median(hist, n - 1)
    dev = np.zeros(256, np.int64)
    for v in range(256):
        dev[abs(v - med)] += hist[v]
    return med, upper_median(dev, n - 1)


@njit(cache=True)
def open2(dmax, level, mask):  # pragma: no cover (compiled)
    """``mask`` (h, w) uint8: 255 where ``dmax`` (h, w) uint8 exceeds ``level`` (int),
    opened by a 2x2 square anchored at its lower right (OpenCV's centre of a 2x2 kernel):
    a minimum, then a maximum, over each pixel and its upper and left neighbours."""
    h, w = dmax.shape
    above = np.empty((h, w), np.uint8)
    for y in range(h):
        row, out = dmax[y], above[y]
        for x in range(w):
            out[x] = row[x] > level
    ero = np.empty((h, w), np.uint8)
    _corner(above, ero, True)
    _corner(ero, above, False)
    for y in range(h):
        row, out = above[y], mask[y]
        for x in range(w):
            out[x] = 255 * row[x]


@njit(cache=True)
def _corner(src, dst, low):  # pragma: no cover (compiled)
    """``dst``: the minimum (``low``) or maximum of 0/1 ``src`` over each pixel and its
    upper, left and upper-left neighbours (those inside the image)."""
    h, w = src.shape
    for y in range(h):
        cur, out = src[y], dst[y]
        prev = src[y - 1] if y > 0 else cur
        if low:
            out[0] = cur[0] & prev[0]
            c1, c0, p1, p0, o1 = cur[1:], cur[:-1], prev[1:], prev[:-1], out[1:]
            for x in range(w - 1):
                o1[x] = c1[x] & c0[x] & p1[x] & p0[x]
        else:
            out[0] = cur[0] | prev[0]
            c1, c0, p1, p0, o1 = cur[1:], cur[:-1], prev[1:], prev[:-1], out[1:]
            for x in range(w - 1):
                o1[x] = c1[x] | c0[x] | p1[x] | p0[x]


@njit(cache=True)
def noise_mad(img):  # pragma: no cover (compiled)
    """MAD (grey levels) of the differences of green pixels two apart, on every 16th row
    from 4 of ``img`` (H, W, 3) uint8: the upper median of their absolute deviations
    from their upper median."""
    hist = np.zeros(511, np.int64)
    n = 0
    for y in range(4, img.shape[0], 16):
        for x in range(2, img.shape[1], 2):
            hist[np.int64(img[y, x, 1]) - np.int64(img[y, x - 2, 1]) + 255] += 1
            n += 1
    med = upper_median(hist, n)
    dev = np.zeros(511, np.int64)
    for v in range(511):
        dev[abs(v - med)] += hist[v]
    return upper_median(dev, n)


@njit(cache=True)
def is_shadow(m0, m1, m2, g0, g1, g2, keep):  # pragma: no cover (compiled)
    """Whether a pixel of 3x3 mean (m0, m1, m2) (RGB, integers) over background (g0, g1,
    g2) is shadow: every channel below 0.75 (bg + 1), i.e. 4 mean < 3 (bg + 1), and the
    ratios mean / (bg + 1) (float32; bg + 1 saturated at 255, as ``cv2.add``) within a
    factor ``keep`` (float32, 1 - chroma) of the largest."""
    g0, g1, g2 = np.int64(g0) + 1, np.int64(g1) + 1, np.int64(g2) + 1
    if 4 * m0 >= 3 * g0 or 4 * m1 >= 3 * g1 or 4 * m2 >= 3 * g2:
        return False
    r0 = np.float32(m0) / np.float32(min(g0, 255))
    r1 = np.float32(m1) / np.float32(min(g1, 255))
    r2 = np.float32(m2) / np.float32(min(g2, 255))
    return min(min(r0, r1), r2) > keep * max(max(r0, r1), r2)


@njit(cache=True)
def area_box(pts, s, e):  # pragma: no cover (compiled)
    """(twice the area, x0, y0, x1, y1) of the pixel contour ``pts[s:e]`` (int32): the
    shoelace sum's absolute value (``2 cv2.contourArea``, exact on pixels) and the
    inclusive corners of its bounding box (``cv2.boundingRect`` is x0, y0, x1 - x0 + 1,
    y1 - y0 + 1)."""
    area = 0
    x0, y0 = np.int64(pts[s, 0]), np.int64(pts[s, 1])
    x1, y1 = x0, y0
    for i in range(s, e):
        q = i + 1 if i + 1 < e else s
        px, py = np.int64(pts[i, 0]), np.int64(pts[i, 1])
        area += px * pts[q, 1] - np.int64(pts[q, 0]) * py
        x0, x1, y0, y1 = min(x0, px), max(x1, px), min(y0, py), max(y1, py)
    return abs(area), x0, y0, x1, y1


@njit(cache=True)
def outer_boxes(pts, lengths, hier, min_px, max_px):  # pragma: no cover (compiled)
    """(n, 6) int64 rows (index, x, y, w, h, long) of the outer contours (``hier`` (N, 4)
    int32 as ``cv2.findContours`` gives it with ``RETR_CCOMP``; ``pts`` (P, 2) int32 all N
    contours one after another, ``lengths`` (N,) points each) that may be parts or may
    hold some, in order: at least 12 points, a bounding box (``cv2.boundingRect``) of
    at least 5 px^2 and 4 x the area (``cv2.contourArea``: exact on pixels) at least
    ``min_px``; ``long`` 0 when twice the box's longer side is at most ``max_px``, 1
    when it is longer but its shorter side is at least 8 (a rail, or a part touching
    one), others left out."""
    out = np.empty((lengths.shape[0], 6), np.int64)
    n = start = 0
    for i in range(lengths.shape[0]):
        k = lengths[i]
        s = start
        start += k
        if k < 12 or hier[i, 3] != -1:
            continue
        area, x0, y0, x1, y1 = area_box(pts, s, s + k)
        bw, bh = x1 - x0 + 1, y1 - y0 + 1
        if bw * bh < 5 or 2 * area < min_px:
            continue
        if 2 * max(bw, bh) <= max_px:
            long = 0
        elif min(bw, bh) >= 8:
            long = 1
        else:
            continue
        out[n, 0], out[n, 1], out[n, 2], out[n, 3], out[n, 4], out[n, 5] = i, x0, y0, bw, bh, long
        n += 1
    return out[:n]


@njit(cache=True)
def upper_decile(dmax, mask, x0, y0):  # pragma: no cover (compiled)
    """The smallest value v of ``dmax`` (h, w) uint8 (half scale) such that at least 9 in
    10 of the pixels of ``mask`` (uint8, nonzero inside; full scale, its corner at (x0,
    y0) in the frame) read at most v there (each pixel reads the half-scale pixel holding
    it); -1 for an empty mask."""
    hist = np.zeros(256, np.int64)
    n = 0
    h, w = dmax.shape
    for i in range(mask.shape[0]):
        row = dmax[min((y0 + i) // 2, h - 1)]
        for j in range(mask.shape[1]):
            if mask[i, j]:
                hist[row[min((x0 + j) // 2, w - 1)]] += 1
                n += 1
    if n == 0:
        return -1
    need = (9 * n + 9) // 10  # ceil(0.9 n)
    s = 0
    for v in range(256):
        s += hist[v]
        if s >= need:
            return v
    return 255
