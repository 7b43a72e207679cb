"""Compiled steps of the segmentation (numba), each the exact integer arithmetic of the
OpenCV call it replaces, so the detector's answers do not change:

* ``cv2.copyMakeBorder`` (``BORDER_REFLECT_101``) + ``cv2.medianBlur`` 15x15 of the 1/8-scale
  frame: a sliding-histogram median (Huang, Yang & Tang, *A fast two-dimensional median
  filtering algorithm*, IEEE TASSP 1979) over column histograms, the median tracked
  from row to row (the counts below and up to it updated by the entering and leaving
  rows, then moved by fine and coarse histogram steps);
* ``cv2.resize`` (``INTER_LINEAR``, uint8) of the 1/8-scale background by 8, edges
  repeated, window by window (:mod:`cell.vision._mosaic`): OpenCV's 11-bit fixed-point
  weights (:func:`upscale_axis`), rows combined as its SIMD path does;
* ``cv2.blur`` (rounded to nearest), ``cv2.absdiff`` and the largest channel, at every other
  pixel; ``cv2.threshold`` (uint8: above the floor of the threshold) and the 2x2
  ``cv2.morphologyEx`` opening (anchor at the kernel's centre (1, 1); the border counts
  neither for erosion nor dilation);
* histogram medians and MADs, and the per-pixel shadow test of :mod:`cell.vision._segment`.

One step has no OpenCV counterpart: the Gaussian that smooths a noisy frame (when
``VisionSettings.smooth_sigma`` > 0), separable, in integers (weights in 1/256).
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
    their weights and repeat the edge row (OpenCV's resize does both)."""
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
def lerp_rows(q0, q1, b0, b1, out):  # pragma: no cover (compiled)
    """``out`` (n,) uint8: two rows of horizontally interpolated values (x 2048, shifted
    right by 4: ``q0``, ``q1`` (n,) float32, integers) combined with row weights ``b0``,
    ``b1`` as ``cv2.resize``'s vector path rounds them: the high halves of the 16-bit
    products, then (sum + 2) >> 2, saturated. (Exact in float64: products < 2^27.)"""
    f0, f1 = b0 / 65536.0, b1 / 65536.0
    for e in range(out.shape[0]):
        v0, v1 = np.float64(q0[e]), np.float64(q1[e])
        out[e] = min((np.floor(f0 * v0) + np.floor(f1 * v1) + 2.0) * 0.25, 255.0)


@njit(cache=True)
def interpolate_x(small, j0s, j1s, a0s, a1s, out):  # pragma: no cover (compiled)
    """``out`` (3 n,) float32: small row ``small`` (ws, 3) uint8 interpolated at n
    columns (source columns ``j0s``, ``j1s``, weights ``a0s``, ``a1s`` (n,), see
    :func:`upscale_axis`), x 2048 and shifted right by 4 (for :func:`lerp_rows`)."""
    for x in range(j0s.shape[0]):
        j0, j1, a0, a1 = j0s[x], j1s[x], a0s[x], a1s[x]
        for c in range(3):
            out[3 * x + c] = (np.int64(small[j0, c]) * a0 + np.int64(small[j1, c]) * a1) >> 4


@njit(cache=True)
def median15(small, bg):  # pragma: no cover (compiled)
    """``bg`` (h, w, 3) uint8: the 15x15 median of each channel of ``small`` (h, w, 3)
    uint8, borders mirrored (``BORDER_REFLECT_101``)."""
    h, w, nc = small.shape
    hp, wp = h + 14, w + 14
    plane = np.empty((hp, wp), np.uint8)
    fine = np.empty((256, wp), np.uint8)  # column histograms (value, column) ...
    coarse = np.empty((16, wp), np.uint8)  # ... and by 16 values
    hist = np.zeros(256, np.int64)
    med = np.empty(w, np.int64)
    below = np.empty(w, np.int64)  # count < median
    upto = np.empty(w, np.int64)  # count <= median
    cols = np.empty(wp, np.int64)
    for j in range(wp):
        cols[j] = border(j - 7, w)
    for c in range(nc):
        for i in range(hp):
            row = small[border(i - 7, h)]
            for j in range(wp):
                plane[i, j] = row[cols[j], c]
        _median_plane(plane, bg, c, fine, coarse, hist, med, below, upto)


@njit(cache=True)
def _window_count(hists, x, v):  # pragma: no cover (compiled)
    s = 0
    for j in range(x, x + 15):
        s += hists[v, j]
    return s


@njit(cache=True)
def _median_plane(q, bg, c, fine, coarse, hist, med, below, upto):  # pragma: no cover
    hp, wp = q.shape
    h, w = hp - 14, wp - 14
    half = 112  # the median of 225 values has 112 below it
    fine[:] = 0
    coarse[:] = 0
    for i in range(15):
        for j in range(wp):
            fine[q[i, j], j] += 1
            coarse[q[i, j] >> 4, j] += 1
    hist[:] = 0  # the first row: Huang's sliding histogram along it
    for i in range(15):
        for j in range(15):
            hist[q[i, j]] += 1
    m, lt = 0, 0
    for x in range(w):
        if x > 0:
            for i in range(15):
                a, b = q[i, x - 1], q[i, x + 14]
                hist[a] -= 1
                hist[b] += 1
                lt += (b < m) - (a < m)
        while lt > half:
            m -= 1
            lt -= hist[m]
        while lt + hist[m] <= half:
            lt += hist[m]
            m += 1
        med[x], below[x], upto[x] = m, lt, lt + hist[m]
        bg[0, x, c] = m
    for y in range(1, h):
        out_row, in_row = q[y - 1], q[y + 14]
        for d in range(15):
            for x in range(w):
                m, a, b = med[x], out_row[x + d], in_row[x + d]
                below[x] += (b < m) - (a < m)
                upto[x] += (b <= m) - (a <= m)
        for j in range(wp):
            a, b = out_row[j], in_row[j]
            if a != b:
                fine[a, j] -= 1
                fine[b, j] += 1
                coarse[a >> 4, j] -= 1
                coarse[b >> 4, j] += 1
        for x in range(w):
            m, lt, le = med[x], below[x], upto[x]
            if lt > half:  # the median fell: walk down, 16 values at a time where possible
                v = m - 1
                while True:
                    if v & 15 == 15:
                        n = _window_count(coarse, x, v >> 4)
                        if lt - n > half:
                            lt -= n
                            v -= 16
                            continue
                    n = _window_count(fine, x, v)
                    if lt - n <= half:
                        m, le, lt = v, lt, lt - n
                        break
                    lt -= n
                    v -= 1
                med[x], below[x], upto[x] = m, lt, le
            elif le <= half:  # it rose: walk up
                v, lt = m + 1, le
                while True:
                    if v & 15 == 0:
                        n = _window_count(coarse, x, v >> 4)
                        if lt + n <= half:
                            lt += n
                            v += 16
                            continue
                    n = _window_count(fine, x, v)
                    if lt + n > half:
                        m, le = v, lt + n
                        break
                    lt += n
                    v += 1
                med[x], below[x], upto[x] = m, lt, le
            bg[y, x, c] = m


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
    for y in range(dmax.shape[0]):
        if (y % 4 == 2) == sample:
            _max_diff_half(img[2 * y], bgh[y], dmax[y])


@njit(cache=True)
def max_diff(src, bg, diff, out):  # pragma: no cover (compiled)
    """``out`` (w,): the largest channel difference of RGB row ``src`` (3 w,) uint8 from
    ``bg`` (3 w,) uint8; ``diff`` (3 w,) uint8 scratch."""
    for e in range(diff.shape[0]):
        diff[e] = abs(np.int16(src[e]) - np.int16(bg[e]))
    for x in range(out.shape[0]):
        out[x] = max(max(diff[3 * x], diff[3 * x + 1]), diff[3 * x + 2])


@njit(cache=True)
def _max_diff_half(src, bg, out):  # pragma: no cover (compiled)
    """``out`` (w,): the largest channel difference of every other pixel of ``src``
    (3 W,) from ``bg`` (3 w,)."""
    for x in range(out.shape[0]):
        d0 = abs(np.int64(src[6 * x]) - np.int64(bg[3 * x]))
        d1 = abs(np.int64(src[6 * x + 1]) - np.int64(bg[3 * x + 1]))
        d2 = abs(np.int64(src[6 * x + 2]) - np.int64(bg[3 * x + 2]))
        out[x] = max(max(d0, d1), d2)


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
            for j in range(r):  # the mirrored columns
                for c in range(3):
                    colf[3 * j + c] = inner[3 * border(j - r, ww) + c]
                    colf[3 * (r + ww + j) + c] = inner[3 * border(ww + j, ww) + c]
            smooth_row(colf, taps, accf, box)
            _max_diff_half(box, bgh[y], dmax[y])
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
        for j in range(r):  # the mirrored columns
            for c in range(3):
                col[3 * j + c] = inner[3 * border(j - r, ww) + c]
                col[3 * (r + ww + j) + c] = inner[3 * border(ww + j, ww) + c]
        box_row(col, k, acc, box)
        _max_diff_half(box, bgh[y], dmax[y])


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
