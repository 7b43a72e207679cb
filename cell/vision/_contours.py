"""The borders of a binary image as ``cv2.findContours(mask, cv2.RETR_CCOMP,
cv2.CHAIN_APPROX_NONE)`` traces them, in one compiled call (numba) that returns flat
arrays (all points one contour after another, with its hierarchy) instead of one numpy
array per contour, which is most of OpenCV's cost on a mask of many specks.

The algorithm is OpenCV's (imgproc/src/contours_new.cpp, its implementation since 4.10), after
Suzuki and Abe, *Topological structural analysis of digitized binary images by border following*,
CVGIP 1985: the mask, framed by one empty pixel, is scanned row by row; a 0 -> 1 step
starts an outer border, a labelled-or-1 -> 0 step a hole border, each followed
counter-clockwise and its pixels labelled (1..127, wrapping; the high bit where the border
leaves to the right). An outer border is a child of the root (``RETR_CCOMP``); a hole
border's parent is the border last met on its row (among those of the same label, told
apart by following them again), or that border's parent when it is a hole too. The
contours come out as OpenCV lists its tree: depth first, the newest child first (both in
:mod:`cell.vision._contourtree`).
``tests/vision/test_contours.py`` checks points and hierarchy against
``cv2.findContours`` on masks of every kind.
"""

from __future__ import annotations

import sys

import numpy as np
from numba import njit

from cell.vision._contourtree import bounding, first_step, results
from cell.vision._mask_kernel import open3

__all__: list[str] = []  # private to cell.vision

_DX = np.array([1, 1, 0, -1, -1, -1, 0, 1], np.int64)  # OpenCV's chain code steps
_DY = np.array([0, -1, -1, -1, 0, 1, 1, 1], np.int64)
_ONES = np.uint64(0x0101010101010101)
_ZERO = np.uint64(0)
# the lowest set bit's index by a de Bruijn multiply: bit i lands in slot
# (2^i * B mod 2^64) >> 58, a different slot for each i
_DEBRUIJN = 0x03F79D71B4CB0A89
_BIT_AT = np.argsort([((1 << i) * _DEBRUIJN & (1 << 64) - 1) >> 58 for i in range(64)])
assert sys.byteorder == "little"  # (a word is 8 pixels, the leftmost in its lowest byte)


def contours(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pts (P, 2) int32, starts (n + 1,) int64, hier (n, 4) int32) of uint8 ``mask`` (H,
    W): contour i is ``pts[starts[i]:starts[i + 1]]`` and ``hier[i]`` its next, previous,
    first child and parent (-1: none), exactly as ``cv2.findContours(mask,
    cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)`` gives them (n = 0 where it gives none)."""
    return _trace(np.ascontiguousarray(mask), _DX, _DY)


def opened_contours(mask: np.ndarray, x: int, y: int, w: int, h: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`contours` of ``cv2.morphologyEx(mask[y : y + h, x : x + w],
    cv2.MORPH_OPEN, np.ones((3, 3)))`` (uint8 ``mask``), the opening compiled too
    (:func:`~cell.vision._mask_kernel.open3`)."""
    return _trace(_opened(np.ascontiguousarray(mask), x, y, w, h), _DX, _DY)


@njit(cache=True)
def _opened(mask, x0, y0, w, h):  # pragma: no cover (compiled)
    """The 3x3 opening of ``mask[y0 : y0 + h, x0 : x0 + w]`` (nonzero: set), 0/1, as a
    view (h, w)."""
    m = np.empty((h + 2) * (w + 2), np.uint8)
    framed = m.reshape((h + 2, w + 2))
    for y in range(h):
        src, out = mask[y0 + y, x0 : x0 + w], framed[y + 1]
        for x in range(w):
            out[x + 1] = src[x] != 0
    open3(m, np.empty_like(m), np.empty_like(m), h, w)
    return framed[1 : h + 1, 1 : w + 1]


@njit(cache=True)
def _first_byte(d):  # pragma: no cover (compiled)
    """The index of the lowest nonzero byte of ``d`` (uint64, not 0)."""
    return _BIT_AT[((d & (_ZERO - d)) * np.uint64(_DEBRUIJN)) >> np.uint64(58)] >> 3


@njit(cache=True)
def _grow(a, n):  # pragma: no cover (compiled)
    """``a`` (its first axis) at least ``n`` long: a copy twice as long when it is not."""
    if a.shape[0] >= n:
        return a
    b = np.empty((max(2 * a.shape[0], n),) + a.shape[1:], a.dtype)
    b[: a.shape[0]] = a
    return b


@njit(cache=True)
def _trace(mask, dx, dy):  # pragma: no cover (compiled)
    """:func:`contours` compiled; ``dx``, ``dy`` the chain code's steps."""
    h, w = mask.shape
    # 0/1, framed by (at least) one empty pixel: pixel (y, x) of the framed image at
    # y stride + x + 7, so that each row's pixels from x = 1 fill whole 8-byte words; a
    # stop mark (2) at x = w + 2 in each row ends a scan over words of 0s (the tracing
    # never reads beyond x = w + 1)
    stride = (w + 16) // 8 * 8
    img = np.zeros((h + 2) * stride + 8, np.uint8)
    for y in range(h + 2):
        img[y * stride + w + 9] = 2
    for y in range(h):
        src, out = mask[y], img[(y + 1) * stride + 8 : (y + 1) * stride + 8 + w]
        for x in range(w):
            out[x] = src[x] != 0
    img = img[7:]  # (x + 7 above)
    words = img[1:].view(np.uint64)  # (the words from x = 1; only whole words used)
    delta = np.empty(16, np.int64)
    for s in range(16):
        delta[s] = dx[s & 7] + dy[s & 7] * stride
    # per contour, in the order found (0: the root, a hole framing the image)
    node = np.empty((64, 11), np.int64)  # parent, first child, prev, next, ctable next,
    node[0, :5] = -1  # hole?, origin (flat), rect x, y, w, h (framed coordinates)
    node[0, 5], node[0, 6] = 1, 0
    node[0, 7], node[0, 8], node[0, 9], node[0, 10] = 0, 0, w + 2, h + 2
    span = np.empty((64, 2), np.int64)  # each contour's points in ``pts``
    pts = np.empty((4 * (w + h) + 64, 2), np.int32)
    n_pts = 0
    n = 1
    ctable = np.full(128, -1, np.int64)
    nbd = 2
    width, height = w + 1, h + 1
    for y in range(1, height):
        row = y * stride
        last_x = 0
        prev = 0
        x = 1
        while x < width:
            # on to the next start of a border: a 1 after a 0 (outer), a 0 after a 1 or a
            # label without the right mark (hole); runs of 0s or 1s a word at a time
            p = img[row + x]
            while True:
                if prev <= 1:  # a run of 0s or 1s: to its end a word at a time (1s end
                    rep = _ONES if prev else _ZERO  # by x = w + 1, 0s by the mark)
                    k = (row + x - 1) >> 3
                    skip = np.uint64(8 * ((x - 1) & 7))
                    d = (words[k] ^ rep) >> skip << skip  # (the bytes before x left out)
                    while d == 0:
                        k += 1
                        d = words[k] ^ rep
                    x = (k << 3) + 1 - row + _first_byte(d)
                    if x >= width:
                        break
                    p = img[row + x]
                if (prev == 0 and p == 1) or (p == 0 and 1 <= prev <= 127):
                    break
                if p != prev and p > 1:
                    last_x = x
                prev = p
                x += 1
                if x >= width:
                    break
                p = img[row + x]
            if x >= width:
                break
            is_hole = p == 0
            if is_hole and prev != 1:
                last_x = x - 1
            # a new border: its parent
            parent = 0
            if is_hole and last_x > 0:
                lval = img[row + last_x] & 127
                parent = bounding(img, node, ctable[lval], last_x, y, stride, delta)
                if node[parent, 5] == 1:  # a hole's hole: the parent's parent
                    parent = node[parent, 0] if node[parent, 0] != -1 else 0
            last_x = x - 1 if is_hole else x
            lval = nbd
            nbd = (nbd + 1) & 127
            if nbd == 0:
                nbd = 3
            if n == node.shape[0]:
                node, span = _grow(node, n + 1), _grow(span, n + 1)
            start = row + x - (1 if is_hole else 0)
            pts = _grow(pts, n_pts + 8)
            n_pts0 = n_pts
            pts, n_pts, rx, ry, rw, rh = _follow(img, start, stride, is_hole, np.uint8(lval),
                                                 delta, dx, dy, pts, n_pts)
            node[n, 0], node[n, 2], node[n, 3] = parent, -1, node[parent, 1]
            if node[parent, 1] != -1:
                node[node[parent, 1], 2] = n
            node[parent, 1] = n
            node[n, 1] = -1
            node[n, 4], ctable[lval] = ctable[lval], n
            node[n, 5], node[n, 6] = is_hole, start
            node[n, 7], node[n, 8], node[n, 9], node[n, 10] = rx, ry, rw, rh
            span[n, 0], span[n, 1] = n_pts0, n_pts
            n += 1
            # go on after it, from what its tracing left there
            x += 1
            prev = img[row + x - 1]
    return results(node, span, pts, n)


@njit(cache=True)
def _follow(img, i0, stride, is_hole, nbd, delta, dx, dy, pts, n_pts):  # pragma: no cover
    """Follow the border from flat index ``i0`` (an outer border's or a hole's first
    pixel), labelling its pixels ``nbd`` (| 128 where the border leaves to the right) and
    appending its points to ``pts`` (grown as needed); (pts, n_pts, rect x, y, w, h) with
    the rectangle OpenCV keeps (framed coordinates; corners only where the direction
    turns) for telling borders of one label apart."""
    py, px = i0 // stride, i0 % stride
    rx, ry, rx1, ry1 = px, py, px, py
    s, i1 = first_step(img, i0, is_hole, delta)
    if s == (0 if is_hole else 4):  # a single pixel
        img[i0] = nbd | 128
        pts = _grow(pts, n_pts + 1)
        pts[n_pts, 0], pts[n_pts, 1] = px - 1, py - 1
        return pts, n_pts + 1, rx, ry, 1, 1
    i3 = i0
    prev_s = s ^ 4
    while True:
        s_end = s
        i4 = i3
        while s < 15:  # (next_step written out: at every border pixel a call cost 20 %)
            s += 1
            i4 = i3 + delta[s]
            if img[i4] != 0:
                break
        s &= 7
        if 1 <= s <= s_end:
            img[i3] = nbd | 128
        elif img[i3] == 1:
            img[i3] = nbd
        if n_pts == pts.shape[0]:
            pts = _grow(pts, n_pts + 1)
        pts[n_pts, 0], pts[n_pts, 1] = px - 1, py - 1
        n_pts += 1
        if s != prev_s:
            if px < rx:
                rx = px
            elif px > rx1:
                rx1 = px
            if py < ry:
                ry = py
            elif py > ry1:
                ry1 = py
        prev_s = s
        px += dx[s]
        py += dy[s]
        if i4 == i0 and i3 == i1:
            break
        i3 = i4
        s = (s + 4) & 7
    return pts, n_pts, rx, ry, rx1 - rx + 1, ry1 - ry + 1
