"""Compiled pixel statistics of the material classifier, and its albedo prior (numba).

:func:`statistics` measures one part's interior pixels in its frame (or a patch): pixel
count, mean colour and its length, unclipped pixels, and, on the flatter, lit half of the
pixels, the pixel count and the robust scales of the high-pass residual along and across
the mean colour, which :func:`cell.vision.material.features_from_statistics` turns into
features. :func:`metal_prior` is the albedo's P(metal) against the catalogue finishes.

The filters read the interior's bounding box and ``SUPPORT`` px around it, mirrored
beyond it (``cv2.BORDER_REFLECT_101``), and reproduce OpenCV's integer arithmetic: grey
(``cv2.COLOR_RGB2GRAY``, coefficients 9798/19235/3735 >> 15, rounded), 3x3 means
(``cv2.blur``, rounded to nearest), the 3x3 Sobel (``cv2.spatialGradient``), and the colour
projection of ``cv2.transform`` (float32, fused multiply-adds in the order OpenCV's
compiled code uses on this CPU), so the features equal those of the OpenCV pipeline bit for
bit (``tests/vision/test_material.py``). Order statistics are element ``n // 2`` in order
(an upper median).
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from cell.vision._segment_kernel import border

__all__: list[str] = []  # private to cell.vision

SUPPORT = 2  # px: how far the filters (3x3 mean, then 3x3 Sobel) read around a pixel
# columns of a statistics row
N, KEPT, MEAN, NORM, S_PAR, S_NOISE2, UNCLIPPED = 0, 1, 2, 5, 6, 7, 8
N_STATS = 9


def patch_statistics(patch: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The statistics row (N_STATS,) of the pixels ``mask`` (uint8 (h, w), nonzero: at
    least 8) of a uint8 RGB ``patch`` (h, w, 3), both C-contiguous, the filters seeing the
    patch mirrored at its border."""
    out = np.zeros(N_STATS)
    statistics(patch, 0, 0, mask, 0, mask.shape[0], 0, mask.shape[1], out)
    return out


@njit(cache=True)
def first_reaching(hist, count):  # pragma: no cover (compiled)
    """The first bin at which the cumulative ``hist`` reaches ``count``."""
    s = 0
    for b in range(hist.shape[0]):
        s += hist[b]
        if s >= count:
            return b
    return hist.shape[0]


@intrinsic
def _fma32(typingctx, a, b, c):  # pragma: no cover (compiled)
    """a * b + c in float32, rounded once (LLVM's fma)."""
    sig = types.float32(types.float32, types.float32, types.float32)

    def codegen(context, builder, signature, args):
        f = ir.FloatType()
        fn = builder.module.declare_intrinsic("llvm.fma", [f], ir.FunctionType(f, [f, f, f]))
        return builder.call(fn, args)

    return sig, codegen


@njit(cache=True)
def _padded(img, y0, x0, ph, pw):  # pragma: no cover (compiled)
    """The patch ``img[y0 : y0 + ph, x0 : x0 + pw]`` with ``SUPPORT`` px mirrored around
    it (``cv2.copyMakeBorder``, ``cv2.BORDER_REFLECT_101``), flattened: (ph + 4) rows of
    (pw + 4) RGB pixels."""
    p = SUPPORT
    ww = pw + 2 * p
    flat, stride = img.reshape(-1), 3 * img.shape[1]
    out = np.empty((ph + 2 * p) * ww * 3, np.uint8)
    for a in range(ph + 2 * p):
        src = flat[(y0 + border(a - p, ph)) * stride + 3 * x0 :]
        dst = out[3 * a * ww :]
        mid = dst[3 * p :]
        for k in range(3 * pw):
            mid[k] = src[k]
        for b in range(p):
            left, right = 3 * border(b - p, pw), 3 * border(pw + b, pw)
            for c in range(3):
                dst[3 * b + c] = src[left + c]
                dst[3 * (p + pw + b) + c] = src[right + c]
    return out


@njit(cache=True)
def statistics(img, y0, x0, mask, ya, yb, xa, xb, out):  # pragma: no cover (compiled)
    """The statistics row of the pixels ``mask[ya:yb, xa:xb]`` (nonzero) of the patch
    ``img[y0 + ya : y0 + yb, x0 + xa : x0 + xb]``, mirrored beyond it."""
    ph, pw = yb - ya, xb - xa
    p = SUPPORT
    ww = pw + 2 * p
    size = (ph + 2 * p) * ww
    pix = _padded(img, y0 + ya, x0 + xa, ph, pw)
    grey = np.empty(size, np.int32)
    for i in range(size):
        grey[i] = (9798 * np.int32(pix[3 * i]) + 19235 * np.int32(pix[3 * i + 1])
                   + 3735 * np.int32(pix[3 * i + 2]) + 16384) >> 15
    across = np.zeros(size, np.int32)  # 3-sums along rows (wrong, unused, at the edges)
    a, g0, g1, g2 = across[1:], grey[: size - 2], grey[1:], grey[2:]
    for i in range(size - 2):
        a[i] = g0[i] + g1[i] + g2[i]
    lit = np.zeros(size, np.int32)  # the 3x3 mean of grey (cv2.blur), 1 px in from the frame
    d, a0, a1, a2 = lit[ww:], across[: size - 2 * ww], across[ww:], across[2 * ww :]
    for i in range(size - 2 * ww):
        d[i] = _div9(a0[i] + a1[i] + a2[i] + 4)
    # the 3x3 Sobel's (cv2.spatialGradient's) squared length, 2 px in from the frame
    slope = np.zeros(size, np.int32)
    k = 2 * ww + 2
    m = size - 2 * k
    d, up, mid, down = slope[k:], lit[k - ww - 1 :], lit[k - 1 :], lit[k + ww - 1 :]
    for i in range(m):
        gx = up[i + 2] + 2 * mid[i + 2] + down[i + 2] - up[i] - 2 * mid[i] - down[i]
        gy = down[i] + 2 * down[i + 1] + down[i + 2] - up[i] - 2 * up[i + 1] - up[i + 2]
        d[i] = gx * gx + gy * gy
    at = np.empty(ph * pw, np.int64)
    n = 0
    for r in range(ph):
        row = mask[ya + r, xa:xb]
        base = (r + p) * ww + p
        for b in range(pw):
            if row[b]:
                at[n] = base + b
                n += 1
    ranked = np.empty(n, np.int32)
    hist = np.zeros(256, np.int64)
    s0 = s1 = s2 = unclipped = 0
    for j in range(n):
        i = at[j]
        ranked[j] = slope[i]
        hist[lit[i]] += 1
        c0, c1, c2 = pix[3 * i], pix[3 * i + 1], pix[3 * i + 2]
        s0, s1, s2 = s0 + c0, s1 + c1, s2 + c2
        unclipped += max(c0, c1, c2) <= 253
    half = n // 2
    slope_q = _select(ranked, half)
    lit_q = first_reaching(hist, half + 1)
    scale = 1.0 / n
    m0, m1, m2 = s0 * scale, s1 * scale, s2 * scale
    norm = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
    if norm > 1e-6:
        u0, u1, u2 = np.float32(m0 / norm), np.float32(m1 / norm), np.float32(m2 / norm)
    else:  # a black part: any direction will do
        u0 = u1 = u2 = np.float32(1.0 / math.sqrt(3.0))
    flat = np.empty(n, np.int64)  # only the flatter, lit half: off shading and the
    kept = 0  # shadow terminator (compacted without branches)
    for j in range(n):
        i = at[j]
        flat[kept] = i
        kept += (slope[i] <= slope_q) & (lit[i] >= lit_q)
    par = np.empty(kept, np.float32)
    dev = np.empty(kept, np.float32)
    orth2 = np.empty(kept, np.float32)
    for j in range(kept):
        i = 3 * flat[j]
        r0 = np.float32(pix[i]) - np.float32(_mean3(pix, i, 3 * ww))
        r1 = np.float32(pix[i + 1]) - np.float32(_mean3(pix, i + 1, 3 * ww))
        r2 = np.float32(pix[i + 2]) - np.float32(_mean3(pix, i + 2, 3 * ww))
        along = _fma32(u2, r2, _fma32(u0, r0, u1 * r1))  # cv2.transform's arithmetic
        par[j] = dev[j] = along
        orth2[j] = (r0 * r0 + r1 * r1 + r2 * r2) - along * along
    out[N], out[KEPT], out[UNCLIPPED] = n, kept, unclipped
    out[MEAN], out[MEAN + 1], out[MEAN + 2], out[NORM] = m0, m1, m2, norm
    if kept:
        half = kept // 2
        med = _select(par, half)
        for j in range(kept):
            dev[j] = abs(dev[j] - med)
        out[S_PAR] = 1.4826 * np.float64(_select(dev, half))
        out[S_NOISE2] = _select(orth2, half)


@njit(cache=True, inline="always")
def _mean3(pix, i, stride):  # pragma: no cover (compiled)
    """``cv2.blur`` (3x3, rounded) at byte ``i`` of the flattened padded RGB patch ``pix``
    (one channel; rows ``stride`` bytes apart)."""
    s = np.int32(0)
    for j in (i - stride, i, i + stride):
        s += np.int32(pix[j - 3]) + np.int32(pix[j]) + np.int32(pix[j + 3])
    return _div9(s + 4)


@njit(cache=True, inline="always")
def _div9(x):  # pragma: no cover (compiled)
    """``x // 9`` for 0 <= x < 2**14 (9 * 255 + 4 at most here), by a multiply and a
    shift (exact there: 58255 / 2**19 exceeds 1/9 by less than 1 / (9 * 2**14))."""
    return (x * 58255) >> 19


@njit(cache=True)
def _select(v, k):  # pragma: no cover (compiled)
    """Element ``k`` of ``v`` in order (as ``np.partition(v, k)[k]``); ``v`` is reordered.
    Quickselect (median-of-three pivot) with branch-free partitions: below the pivot,
    then equal to it (the data's order is unpredictable, so branches would mostly miss)."""
    lo, hi = 0, v.shape[0]
    while hi - lo > 1:
        a, b, c = v[lo], v[(lo + hi) >> 1], v[hi - 1]
        pivot = max(min(a, b), min(max(a, b), c))
        j = lo
        for i in range(lo, hi):
            x = v[i]
            v[i] = v[j]
            v[j] = x
            j += x < pivot
        if k < j:
            hi = j
            continue
        e = j
        for i in range(j, hi):
            x = v[i]
            v[i] = v[e]
            v[e] = x
            e += x == pivot
        if k < e:
            return pivot
        lo = e
    return v[k]


@njit(cache=True)
def metal_prior(albedo, finishes, metal, sigma2):  # pragma: no cover (compiled)
    """P(metal) (P,) of albedos (P, 3) from the finishes' albedos (K, 3) and whether each is
    a metal (K,) bool: the share of the metals in the softmax of -d2 / 2, d2 the squared
    distance over ``sigma2``; sums in numpy's order (``ndarray.sum``: pairwise in blocks
    of 8), so the result is numpy's bit for bit."""
    out = np.empty(albedo.shape[0])
    n_k = finishes.shape[0]
    d2 = np.empty(n_k)
    w = np.empty(n_k)
    metals = np.empty(n_k)
    for q in range(albedo.shape[0]):
        for k in range(n_k):
            a = finishes[k, 0] - albedo[q, 0]
            b = finishes[k, 1] - albedo[q, 1]
            c = finishes[k, 2] - albedo[q, 2]
            d2[k] = (a * a + b * b + c * c) / sigma2
        low = d2.min()
        m = 0
        for k in range(n_k):
            w[k] = math.exp(-(d2[k] - low) / 2)
            if metal[k]:
                metals[m] = w[k]
                m += 1
        out[q] = _numpy_sum(metals[:m]) / _numpy_sum(w)
    return out


@njit(cache=True)
def _numpy_sum(v):  # pragma: no cover (compiled)
    """``v.sum()`` of at most 128 values in numpy's order (pairwise_sum: under 8 values in
    turn; else 8 running sums of every 8th value, added pairwise, then the rest in turn)."""
    n = v.shape[0]
    if n < 8:
        s = -0.0
        for i in range(n):
            s += v[i]
        return s
    r = v[:8].copy()
    top = n - n % 8
    for i in range(8, top, 8):
        for j in range(8):
            r[j] += v[i + j]
    s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    for i in range(top, n):
        s += v[i]
    return s
