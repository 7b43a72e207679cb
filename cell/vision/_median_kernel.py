"""The 15x15 median of the 1/8-scale frame (the detector's belt estimate), compiled.

Exactly ``cv2.copyMakeBorder`` (``BORDER_REFLECT_101``) + ``cv2.medianBlur`` 15x15 of a
uint8 RGB image: a sliding-histogram median (Huang, Yang & Tang, *A fast two-dimensional
median filtering algorithm*, IEEE TASSP 1979) over column histograms, the median tracked
from row to row (the counts below and up to it updated by the entering and leaving rows,
then moved by fine and coarse histogram steps).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cell.vision._segment_kernel import border

__all__: list[str] = []  # private to cell.vision


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
    med = np.empty(w, np.int16)  # (16-bit: the counts' updates vectorize 16 wide)
    below = np.empty(w, np.int16)  # count < median
    upto = np.empty(w, np.int16)  # count <= median
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
def _counts(out_row, in_row, med, below, upto):  # pragma: no cover (compiled)
    """Move the counts of values below (``below``) and up to (``upto``) each column's
    median ``med`` from the window rows' leaving row ``out_row`` to the entering
    ``in_row`` (15 columns from x each)."""
    for d in range(15):
        for x in range(med.shape[0]):
            m, a, b = med[x], out_row[x + d], in_row[x + d]
            below[x] += (b < m) - (a < m)
            upto[x] += (b <= m) - (a <= m)


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
        _counts(out_row, in_row, med, below, upto)
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
