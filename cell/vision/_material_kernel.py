"""Compiled pixel statistics of the material classifier (numba).

:func:`measure` measures one part's interior pixels in its frame (or, through
:func:`statistics`, in a patch mirrored at its border): pixel count, mean colour and its
length, unclipped pixels, and, on the flatter, lit half of the pixels, the pixel count and
the robust scales of the high-pass residual along and across the mean colour, which
:func:`cell.vision.material.features_from_statistics` turns into features.

The filters read the interior's bounding box and ``SUPPORT`` px around it (a copy of
those pixels, filtered whole, rows wrapping: what a wrap spoils is never read), mirrored
beyond a patch (``cv2.BORDER_REFLECT_101``), and reproduce OpenCV's integer arithmetic: grey
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

from cell.vision._fma import fma
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
    p = SUPPORT
    ww = xb - xa + 2 * p
    pix = _padded(img, y0 + ya, x0 + xa, yb - ya, xb - xa)
    measure(pix, 3 * ((p - ya) * ww + p - xa), 3 * ww, mask, ya, yb, xa, xb, out)


@njit(cache=True)
def measure(src, base, stride, mask, ia, ib, ja, jb, out):  # pragma: no cover (compiled)
    """The statistics row of the pixels ``mask[ia:ib, ja:jb]`` (nonzero; none outside
    that box), pixel (r, c) of ``mask`` being the RGB bytes at ``src[base + r * stride +
    3 * c]`` (flattened uint8), readable ``SUPPORT`` px around the box: an image itself
    where the patch lies inside it, else a mirrored copy (:func:`statistics`)."""
    p = SUPPORT
    bh, bw = ib - ia, jb - ja
    gh, gw = bh + 2 * p, bw + 2 * p  # the box and the support around it, flattened
    size = gh * gw
    pix = np.empty(3 * size, np.uint8)
    org = base + (ia - p) * stride + 3 * (ja - p)
    for a in range(gh):
        row, dst = src[org + a * stride :], pix[3 * a * gw :]
        for k in range(3 * gw):
            dst[k] = row[k]
    grey = np.empty(size, np.int32)
    for i in range(size):
        grey[i] = (9798 * np.int32(pix[3 * i]) + 19235 * np.int32(pix[3 * i + 1])
                   + 3735 * np.int32(pix[3 * i + 2]) + 16384) >> 15
    lit = np.zeros(size, np.int32)
    _box3(grey, 1, gw, lit)  # the 3x3 mean of grey (cv2.blur), 1 px in from the frame
    # the 3x3 Sobel's (cv2.spatialGradient's) squared length, 2 px in from the frame
    slope = np.zeros(size, np.int32)
    k = 2 * gw + 2
    m = size - 2 * k
    d, up, mid, down = slope[k:], lit[k - gw - 1 :], lit[k - 1 :], lit[k + gw - 1 :]
    for i in range(m):
        gx = up[i + 2] + 2 * mid[i + 2] + down[i + 2] - up[i] - 2 * mid[i] - down[i]
        gy = down[i] + 2 * down[i + 1] + down[i + 2] - up[i] - 2 * up[i + 1] - up[i + 2]
        d[i] = gx * gx + gy * gy
    # the part's pixels: their places, slopes and grey histogram (four, taken in turn, so
    # equal values in a row do not wait on each other's count), colour sums per column
    at = np.empty(bh * bw, np.uint64)
    ranked = np.empty(bh * bw, np.int32)
    hist = np.zeros((4, 256), np.int32)
    acc = np.zeros((4, bw), np.uint16)  # R, G, B, unclipped; at most 256 rows at a time
    cnt = np.uint64(0)  # (unsigned indices: numba tests signed ones for wrapping around)
    s0 = s1 = s2 = unclipped = 0
    for r in range(bh):
        row = mask[ia + r, ja:jb]
        k = (r + p) * gw + p
        sl, lt, px = slope[k:], lit[k:], pix[3 * k :]
        for c in range(bw):
            inside = np.uint64(row[c] != 0)
            at[cnt] = k + c
            ranked[cnt] = sl[c]
            hist[np.uint64(c & 3), np.uint64(lt[c])] += np.int32(inside)
            cnt += inside
        for c in range(bw):
            on = np.uint8(0) - np.uint8(row[c] != 0)
            c0, c1, c2 = px[3 * c], px[3 * c + 1], px[3 * c + 2]
            acc[0, c] += c0 & on
            acc[1, c] += c1 & on
            acc[2, c] += c2 & on
            acc[3, c] += np.uint8(max(max(c0, c1), c2) <= 253) & on
        if r & 255 == 255 or r == bh - 1:
            for c in range(bw):
                s0, s1, s2 = s0 + acc[0, c], s1 + acc[1, c], s2 + acc[2, c]
                unclipped += acc[3, c]
            acc[:] = 0
    n = np.int64(cnt)
    half = n // 2
    slope_q = _select(ranked[:n], half)
    counts = np.empty(256, np.int64)
    for b in range(256):
        counts[b] = hist[0, b] + hist[1, b] + hist[2, b] + hist[3, b]
    lit_q = first_reaching(counts, half + 1)
    scale = 1.0 / n
    m0, m1, m2 = s0 * scale, s1 * scale, s2 * scale
    norm = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
    if norm > 1e-6:
        u0, u1, u2 = np.float32(m0 / norm), np.float32(m1 / norm), np.float32(m2 / norm)
    else:  # a black part: any direction will do
        u0 = u1 = u2 = np.float32(1.0 / math.sqrt(3.0))
    flat = np.empty(n, np.uint64)  # only the flatter, lit half: off shading and the
    cnt = np.uint64(0)  # shadow terminator (compacted without branches)
    for j in range(n):
        i = at[j]
        flat[cnt] = i
        cnt += np.uint64((slope[i] <= slope_q) & (lit[i] >= lit_q))
    kept = np.int64(cnt)
    local = np.empty(3 * size, np.uint8)  # the 3x3 mean of each channel (cv2.blur)
    _box3(pix, 3, 3 * gw, local)
    par = np.empty(kept, np.float32)
    dev = np.empty(kept, np.float32)
    orth2 = np.empty(kept, np.float32)
    one, two, three = np.uint64(1), np.uint64(2), np.uint64(3)
    for j in range(kept):
        i = three * flat[j]
        r0 = np.float32(pix[i]) - np.float32(local[i])
        r1 = np.float32(pix[i + one]) - np.float32(local[i + one])
        r2 = np.float32(pix[i + two]) - np.float32(local[i + two])
        along = fma(u2, r2, fma(u0, r0, u1 * r1))  # cv2.transform's arithmetic
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


@njit(cache=True)
def _box3(v, step, stride, out):  # pragma: no cover (compiled)
    """``out`` = the 3x3 means (``cv2.blur``, rounded to nearest) of the flattened image
    ``v`` (values ``step`` apart in a row, rows ``stride`` apart), everywhere 1 px in
    from its frame (wrong, unused, where a row wraps; the frame left as it was)."""
    size = v.shape[0]
    across = np.empty(size, np.int16)  # 3-sums along rows
    a, g0, g1, g2 = across[step:], v[: size - 2 * step], v[step:], v[2 * step :]
    for i in range(size - 2 * step):
        a[i] = np.int16(g0[i]) + np.int16(g1[i]) + np.int16(g2[i])
    d, a0, a1, a2 = out[stride:], across[: size - 2 * stride], across[stride:], across[2 * stride :]
    for i in range(size - 2 * stride):
        d[i] = _div9(np.int32(a0[i]) + np.int32(a1[i]) + np.int32(a2[i]) + np.int32(4))


@intrinsic
def _div9(typingctx, x):  # pragma: no cover (compiled)
    """``x // 9`` for 0 <= x < 2**14 (9 * 255 + 4 at most here), int32, by a multiply and a
    shift in 32 bits (exact there: 58255 / 2**19 exceeds 1/9 by less than 1 / (9 * 2**14));
    numba would widen the product to 64 bits, which AVX2 has no vector multiply for."""
    sig = types.int32(types.int32)

    def codegen(context, builder, signature, args):
        i32 = ir.IntType(32)
        return builder.lshr(builder.mul(args[0], ir.Constant(i32, 58255)), ir.Constant(i32, 19))

    return sig, codegen


@njit(cache=True)
def _select(v, k):  # pragma: no cover (compiled)
    """Element ``k`` of ``v`` in order (as ``np.partition(v, k)[k]``); ``v`` is reordered.
    Quickselect (median-of-three pivot) with branch-free partitions: below the pivot,
    then equal to it (the data's order is unpredictable, so branches would mostly miss).
    Indices are unsigned, so numba adds no test for negative ones to each access."""
    one = np.uint64(1)
    lo, hi, k = np.uint64(0), np.uint64(v.shape[0]), np.uint64(k)
    while hi - lo > one:
        a, b, c = v[lo], v[(lo + hi) >> one], v[hi - one]
        pivot = max(min(a, b), min(max(a, b), c))
        j = lo
        for i in range(lo, hi):
            x = v[i]
            v[i] = v[j]
            v[j] = x
            j += np.uint64(x < pivot)
        if k < j:
            hi = j
            continue
        e = j
        for i in range(j, hi):
            x = v[i]
            v[i] = v[e]
            v[e] = x
            e += np.uint64(x == pivot)
        if k < e:
            return pivot
        lo = e
    return v[k]
