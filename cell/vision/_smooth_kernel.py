"""Smoothing of a noisy frame before it is differenced from the belt, compiled.

At every other pixel (the half-scale foreground) or over a window, with borders mirrored:
a k x k box filter, exactly ``cv2.blur`` (rounded to nearest), or, when
``VisionSettings.smooth_sigma`` > 0, a separable Gaussian in integers (weights in 1/256:
it smooths the sensor noise with less blur of the outlines than a box). For the
half-scale foreground the Gaussian's horizontal pass runs at the even pixels alone, on
each row split into its even and its odd RGB pixels, so that every loop runs over
contiguous arrays (numba vectorises those, not strided ones); its sums, and so its
results, are the same.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

from cell.vision._segment_kernel import border, max_diff, max_diff_half

__all__: list[str] = []  # private to cell.vision

_U = np.uint64  # (unsigned indices: no negative-index checks, so strided loops vectorise)


@functools.lru_cache(maxsize=8)
def smoothing_taps(k: int, sigma: float) -> np.ndarray:
    """(k,) uint16: the Gaussian weights (``sigma`` px, as ``cv2.getGaussianKernel``) of
    a k-tap smoothing filter in 1/256 (rounded; the centre tap takes the rounding so
    that they sum to 256; symmetric); empty for sigma 0 (a box filter) or no filter
    (k = 0). Kept per (k, sigma): read-only."""
    if sigma <= 0 or k == 0:
        return np.empty(0, np.uint16)
    x = np.arange(k) - (k - 1) / 2
    taps = np.exp(-x * x / (2 * sigma * sigma))
    weights = np.rint(256 * taps / taps.sum()).astype(np.int64)
    weights[k // 2] += 256 - weights.sum()
    out = weights.astype(np.uint16)
    out.flags.writeable = False
    return out


@njit(cache=True)
def _weigh(mid, a, b, tm, t, out):  # pragma: no cover (compiled)
    """``out`` = ``tm`` mid + ``t`` (a + b), in int32 (stored in ``out``'s type)."""
    for e in range(out.shape[0]):
        out[e] = tm * np.int32(mid[e]) + t * (np.int32(a[e]) + np.int32(b[e]))


@njit(cache=True)
def _add_pair(a, b, t, out):  # pragma: no cover (compiled)
    """``out`` += ``t`` (a + b), in int32."""
    for e in range(out.shape[0]):
        out[e] += t * (np.int32(a[e]) + np.int32(b[e]))


@njit(cache=True)
def vertical(src, rows, lo, taps, col):  # pragma: no cover (compiled)
    """``col`` (m,) uint16: the vertical pass of the symmetric filter ``taps`` (k,) int32
    (in 1/256), sum_j taps[j] src[rows[j], lo : lo + m] of uint8 rows ``src`` (exact:
    at most 255 x 256)."""
    m, r = col.shape[0], taps.shape[0] // 2
    d = min(r, 1)  # (k = 1: the centre alone)
    _weigh(src[rows[r], lo : lo + m], src[rows[r - d], lo : lo + m],
           src[rows[r + d], lo : lo + m], taps[r], taps[r - 1] if r else np.int32(0), col)
    for j in range(r - 1):  # the pairs further out
        _add_pair(src[rows[j], lo : lo + m], src[rows[-1 - j], lo : lo + m], taps[j], col)


@njit(cache=True)
def gaussian_window(win, wide, h, w, o, taps, col, acc, out):  # pragma: no cover (compiled)
    """``out`` (flat, rows of ``wide``): the window of flat ``win`` (rows of ``wide``
    RGB values, the window's pixels from ``o + k // 2`` px in) smoothed by the
    separable filter ``taps`` (k,) int32 (:func:`vertical`, then
    :func:`horizontal`), pixel (y, x) at ``out[y wide + 3 x]``. Both passes run over
    the whole window at once, across the rows' ends (what lands there is unused);
    ``col`` (uint16) and ``acc`` (int32) scratch."""
    k = taps.shape[0]
    r = k // 2
    n_out = (h - 1) * wide + 3 * w
    n = n_out + 3 * (k - 1)
    base = o * wide + 3 * o
    c = col[:n]
    d = min(r, 1)  # (k = 1: the centre alone)
    mid = win[base + r * wide : base + r * wide + n]
    _weigh(mid, win[base + (r - d) * wide : base + (r - d) * wide + n],
           win[base + (r + d) * wide : base + (r + d) * wide + n], taps[r],
           taps[r - 1] if r else np.int32(0), c)
    for j in range(r - 1):  # the pairs further out
        _add_pair(win[base + j * wide : base + j * wide + n],
                  win[base + (k - 1 - j) * wide : base + (k - 1 - j) * wide + n], taps[j], c)
    horizontal(c, taps, acc, out[:n_out])


@njit(cache=True)
def _round_pair(acc, a, b, t, out):  # pragma: no cover (compiled)
    """``out`` = (acc + ``t`` (a + b) + 32768) >> 16: the 1/65536 sums rounded."""
    for e in range(out.shape[0]):
        out[e] = np.int32(acc[e] + t * (np.int32(a[e]) + np.int32(b[e])) + 32768) >> 16


@njit(cache=True)
def _round_five(mid, a1, b1, a0, b0, taps, out):  # pragma: no cover (compiled)
    """``out`` = (t2 mid + t1 (a1 + b1) + t0 (a0 + b0) + 32768) >> 16 for the five
    ``taps`` (t0, t1, t2, t1, t0): the whole 5-tap pass in one loop (the default
    aperture)."""
    t0, t1, t2 = taps[0], taps[1], taps[2]
    for e in range(out.shape[0]):
        s = t2 * np.int32(mid[e]) + t1 * (np.int32(a1[e]) + np.int32(b1[e])) + t0 * (
            np.int32(a0[e]) + np.int32(b0[e]))
        out[e] = np.int32(s + 32768) >> 16


@njit(cache=True)
def horizontal(col, taps, acc, out):  # pragma: no cover (compiled)
    """``out`` (n,) uint8: the horizontal pass of the symmetric filter ``taps`` (k,)
    int32 (in 1/256) over ``col`` (n + 3 (k - 1),) uint16 (the vertical pass, RGB, k // 2
    px beyond both ends), (sum_j taps[j] col[3 j : 3 j + n] + 32768) >> 16: rounded to
    nearest; ``acc`` (n,) int32 scratch."""
    n, k = out.shape[0], taps.shape[0]
    r = k // 2
    mid = col[3 * r : 3 * r + n]
    if k == 5:  # (the default aperture: one pass)
        _round_five(mid, col[3 : 3 + n], col[9 : 9 + n], col[:n], col[12 : 12 + n], taps, out)
        return
    if r >= 2:
        _weigh(mid, col[3 * (r - 1) : 3 * (r - 1) + n], col[3 * (r + 1) : 3 * (r + 1) + n],
               taps[r], taps[r - 1], acc[:n])
        for j in range(1, r - 1):
            _add_pair(col[3 * j : 3 * j + n], col[3 * (k - 1 - j) : 3 * (k - 1 - j) + n],
                      taps[j], acc[:n])
    else:
        _weigh(mid, mid, mid, taps[r], np.int32(0), acc[:n])
    if r:  # the outermost pair, and rounding
        _round_pair(acc, col[:n], col[3 * (k - 1) : 3 * (k - 1) + n], taps[0], out)
    else:
        _round_pair(acc, mid, mid, np.int32(0), out)


@njit(cache=True)
def _split_pixels(col, ev, od):  # pragma: no cover (compiled)
    """``ev``, ``od`` (3 n,): the even and the odd RGB pixels of ``col`` (6 n,)."""
    for i in range(ev.shape[0] // 3):
        u = _U(i)
        for c in range(3):
            e = _U(6) * u + _U(c)
            ev[_U(3) * u + _U(c)] = col[e]
            od[_U(3) * u + _U(c)] = col[e + _U(3)]


@njit(cache=True)
def _tap(ev, od, j, n):  # pragma: no cover (compiled)
    """The n values under tap ``j`` of the even output pixels, from pixel 2 x + j (the
    even pixels ``ev`` or the odd ``od`` of the padded row)."""
    part = ev if j % 2 == 0 else od
    return part[3 * (j // 2) : 3 * (j // 2) + n]


@njit(cache=True)
def even_horizontal(ev, od, taps, acc, out):  # pragma: no cover (compiled)
    """``out`` (3 w,) uint8: :func:`horizontal` at the even pixels only, from the padded
    row's even and odd pixels ``ev``, ``od`` (:func:`_split_pixels`; output pixel x sums
    padded pixels 2 x .. 2 x + k - 1), on contiguous arrays; ``acc`` (3 w,) int32
    scratch."""
    n, k = out.shape[0], taps.shape[0]
    r = k // 2
    mid = _tap(ev, od, r, n)
    if k == 5:  # (the default aperture: one pass)
        _round_five(mid, od[:n], od[3 : 3 + n], ev[:n], ev[6 : 6 + n], taps, out)
        return
    if r >= 2:
        _weigh(mid, _tap(ev, od, r - 1, n), _tap(ev, od, r + 1, n), taps[r], taps[r - 1], acc)
        for j in range(1, r - 1):
            _add_pair(_tap(ev, od, j, n), _tap(ev, od, k - 1 - j, n), taps[j], acc)
    else:
        _weigh(mid, mid, mid, taps[r], np.int32(0), acc)
    if r:  # the outermost pair, and rounding
        _round_pair(acc, _tap(ev, od, 0, n), _tap(ev, od, k - 1, n), taps[0], out)
    else:
        _round_pair(acc, mid, mid, np.int32(0), out)


@njit(cache=True)
def box_difference(img, bgh, k, taps, dmax):  # pragma: no cover (compiled)
    """``dmax`` (h, w): the largest channel difference between ``bgh`` (h, 3 w) and
    ``img`` (H, 3 W) uint8 (RGB rows) smoothed k x k (borders mirrored) at every other
    pixel: by ``cv2.blur`` (rounded to nearest) when ``taps`` is empty, else by the
    separable filter ``taps`` (in 1/256, symmetric: :func:`vertical`, then
    :func:`even_horizontal` at the even pixels alone), rounded to nearest."""
    hh, n = img.shape
    ww = n // 3
    h, w = dmax.shape
    r = k // 2
    box = np.empty(3 * ww, np.uint8)
    diff = np.empty(3 * w, np.uint8)
    if taps.shape[0]:
        tp = taps.astype(np.int32)
        pairs = (ww + 2 * r + 1) // 2  # the padded row's pixels, in pairs
        col = np.empty(6 * pairs, np.uint16)
        ev, od = np.empty(3 * pairs, np.uint16), np.empty(3 * pairs, np.uint16)
        acc = np.empty(3 * w, np.int32)
        rows = np.empty(k, np.int64)
        for y in range(h):
            for i in range(k):
                rows[i] = border(2 * y - r + i, hh)
            vertical(img, rows, 0, tp, col[3 * r : 3 * (r + ww)])
            _mirror_columns(col, r, ww)
            _split_pixels(col, ev, od)
            even_horizontal(ev, od, tp, acc, box[: 3 * w])
            max_diff(box[: 3 * w], bgh[y], diff, dmax[y])
        return
    col = np.empty(3 * (ww + 2 * r), np.uint16)  # column sums, mirrored past the edges
    acc16 = np.empty(3 * ww, np.uint16)
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
        box_row(col, k, acc16, box)
        max_diff_half(box, bgh[y], diff, dmax[y])


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
