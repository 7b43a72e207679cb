"""Material of every part in a frame at once, from each part's own pixels.

Per part: the interior, away from the edge's blend with the belt (a 5x5 erosion of its
mask ``Blob.roi``, or 3x3 where that leaves fewer than 150 pixels: a square nut's ring is
4 px wide; as ``cv2.erode``'s default border, the erosion does not eat into the ROI's own
edge), and the belt's colour next to it, the mean of the free pixels (``FrameView.fg`` not
255) of the ROI's box and 6 px around it (``cv2.mean``: integer sums times 1/n), which
white-balances its albedo (a part seen against a glowing light table is a silhouette:
``unknown``). One compiled pass (:func:`frame_statistics`) measures every part, with the
pixel statistics of :mod:`cell.vision._material_kernel`; the labels
(:func:`cell.vision.material.materials_from_statistics`) follow for all parts at once.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cell.vision._blob import Blob
from cell.vision._material_kernel import (
    N_STATS,
    SUPPORT,
    first_reaching,
    measure,
    patch_statistics,
    statistics,
)
from cell.vision._segment import FrameView
from cell.vision.material import materials_from_statistics

__all__: list[str] = []  # private to cell.vision

_UNKNOWN = ("unknown", 0.0)
MEASURED, NO_BELT = 1, 2  # part states
_FREE, _BELT = 0, 1  # columns of a belt row: free pixels, mean colour (3)
_PAD = 2  # px of 255 each side of a ROI's rows, so the erosion need not test the row ends
_MIN_FREE = 30  # fewer free pixels than this around a part: the belt is not measured


def part_materials(view: FrameView, blobs: list[Blob]) -> list[tuple[str, float]]:
    """(material, confidence) of each blob, from its ROI's interior (see the module
    docstring); ``unknown`` for a back-lit frame, a blob without ROI, an interior under 8
    pixels, or a part on a light table."""
    out = [_UNKNOWN] * len(blobs)
    if view.backlit:
        return out
    have = [(i, b.roi) for i, b in enumerate(blobs) if b.roi is not None]
    if not have:
        return out
    boxes = np.array([(x0, y0, *m.shape) for _, (x0, y0, m) in have], np.int64)
    masks = np.concatenate([m.reshape(-1) for _, (_, _, m) in have])
    st = view.settings
    stats, belts, state = frame_statistics(view.img, view.fg, boxes, masks, st.backlight_level)
    states = state.tolist()
    for j in [j for j, s in enumerate(states) if s == NO_BELT]:  # hardly any belt around:
        x0, y0, m = have[j][1]  # its estimate at the part's centre
        u = min(x0 + m.shape[1] // 2, view.fg.shape[1] - 1)
        v = min(y0 + m.shape[0] // 2, view.fg.shape[0] - 1)
        belts[j, 1:] = view.background_at(u, v, u + 1, v + 1)[0, 0]
        states[j] = MEASURED if min(belts[j, 1:].tolist()) < st.backlight_level else 0
    rows = [j for j, s in enumerate(states) if s == MEASURED]
    if not rows:
        return out
    if len(rows) < len(states):
        stats, belts = stats[rows], belts[rows]
    labels = materials_from_statistics(
        stats, belts[:, 1:], belt_rgb=st.belt_rgb, noise_sigma=noise_sigma(view.img),
        grain_metal=st.grain_metal, grain_z_min=st.grain_z_min, albedo_sigma=st.albedo_sigma)
    for j, label in zip(rows, labels, strict=True):
        out[have[j][0]] = label
    return out


def frame_statistics(img: np.ndarray, fg: np.ndarray, boxes: np.ndarray, masks: np.ndarray,
                     backlight_level: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Statistics rows (P, N_STATS), belt rows (P, 4: free pixels, mean RGB) and states
    (P,) of the parts of a frame (see the module docstring).

    ``img`` uint8 RGB (H, W, 3) and ``fg`` uint8 (H, W), C-contiguous; ``boxes`` int64
    (P, 4): each part's ROI as x0, y0, height, width; ``masks`` the ROIs (uint8, nonzero
    inside) flattened one after the other. A part's state is ``MEASURED``; ``NO_BELT``
    where fewer than 30 pixels around it are free (the belt's colour is left to the
    caller); or 0: an interior under 8 pixels, or a belt at ``backlight_level`` or
    brighter in every channel (a light table: the part is a silhouette).
    """
    stats = np.zeros((len(boxes), N_STATS))
    belts = np.zeros((len(boxes), 4))
    state = np.zeros(len(boxes), np.int64)
    _frame(img, fg, boxes, masks, float(backlight_level), stats, belts, state)
    return stats, belts, state


@njit(cache=True)
def noise_sigma(img):  # pragma: no cover (compiled)
    """The frame's sensor noise (grey levels), as ``FrameView.noise_sigma`` estimates it:
    1.4826 * the MAD of the green channel's differences of pixels two apart on every
    16th row from row 4, over sqrt(2); upper medians, from a histogram."""
    counts = np.zeros((4, 511), np.int32)  # four histograms in turn: equal differences in a
    total = 0  # row do not wait on each other's count
    for y in range(4, img.shape[0], 16):
        row = img[y]
        m = (img.shape[1] - 1) // 2
        for x in range(m):
            counts[x & 3, np.int32(row[2 * x + 2, 1]) - np.int32(row[2 * x, 1]) + 255] += 1
        total += m
    hist = np.zeros(511, np.int64)
    for d in range(511):
        hist[d] = counts[0, d] + counts[1, d] + counts[2, d] + counts[3, d]
    half = total // 2 + 1
    med = first_reaching(hist, half)
    dev = np.zeros(511, np.int64)
    for d in range(511):
        dev[abs(d - med)] += hist[d]
    return 1.4826 * first_reaching(dev, half) / math.sqrt(2)


@njit(cache=True)
def _frame(img, fg, boxes, masks, level, stats, belts, state):  # pragma: no cover (compiled)
    p = SUPPORT
    off = 0
    for i in range(boxes.shape[0]):
        x0, y0, h, w = boxes[i, 0], boxes[i, 1], boxes[i, 2], boxes[i, 3]
        src = masks[off : off + h * w]
        off += h * w
        # the erosion in the mask's bounding box and 2 px around it (clipped to the ROI):
        # what lies further out is 0 and never reaches the interior
        ya, yb, xa, xb = _extent(src, h, w)
        if ya == yb:
            continue
        ya, yb, xa, xb = max(ya - 2, 0), min(yb + 2, h), max(xa - 2, 0), min(xb + 2, w)
        sh, sw = yb - ya, xb - xa
        roi = np.full((sh, sw + 2 * _PAD), 255, np.uint8)
        for y in range(sh):
            row, dst = src[(ya + y) * w + xa :], roi[y, _PAD:]
            for x in range(sw):
                dst[x] = row[x]
        sel = np.empty_like(roi)
        across = np.empty_like(roi)
        n, ia, ib, ja, jb = _erode(roi, 2, across, sel)
        if n < 150:
            n, ia, ib, ja, jb = _erode(roi, 1, across, sel)
            if n < 8:
                continue
        belt = belts[i]
        _belt(img, fg, max(x0 - 6, 0), max(y0 - 6, 0), min(x0 + w + 6, img.shape[1]),
              min(y0 + h + 6, img.shape[0]), belt)
        if belt[_FREE] >= _MIN_FREE and min(belt[1], belt[2], belt[3]) >= level:
            continue
        state[i] = MEASURED if belt[_FREE] >= _MIN_FREE else NO_BELT
        # the filters read the interior's box and SUPPORT px around it, mirrored beyond
        # the ROI (here: beyond the sub-box, which stops short of it only where the mask
        # does); inside it they read the frame itself
        y, x = y0 + ya, x0 + xa - _PAD
        if ia >= p and ja >= _PAD + p and ib + p <= sh and jb + p <= sw + _PAD:
            measure(img.reshape(-1), 3 * (y * img.shape[1] + x), 3 * img.shape[1], sel,
                    ia, ib, ja, jb, stats[i])
        else:
            statistics(img, y, x, sel, max(ia - p, 0), min(ib + p, sh), max(ja - p, _PAD),
                       min(jb + p, sw + _PAD), stats[i])


@njit(cache=True)
def _extent(mask, h, w):  # pragma: no cover (compiled)
    """The bounding box of the nonzero pixels of ``mask`` (h * w flattened): rows
    [ya, yb), columns [xa, xb); all 0 when there are none."""
    cols = np.zeros(w, np.uint8)
    ya, yb = h, 0
    for y in range(h):
        row = mask[y * w : (y + 1) * w]
        top = np.uint8(0)
        for x in range(w):
            top = max(top, row[x])
            cols[x] = max(cols[x], row[x])
        if top:
            ya, yb = min(ya, y), y + 1
    if yb == 0:
        return 0, 0, 0, 0
    xa, xb = w, 0
    for x in range(w):
        if cols[x]:
            xa, xb = min(xa, x), x + 1
    return ya, yb, xa, xb


@njit(cache=True)
def _erode(roi, r, across, out):  # pragma: no cover (compiled)
    """``out`` = ``roi`` eroded by a (2r+1)-square (r = 1 or 2), separably (rows, then
    columns, through ``across``): nonzero where the whole square is, rows beyond
    ``roi``'s counting as nonzero and its first and last ``_PAD`` >= r columns being 255
    (so the erosion does not eat into the ROI's own edge, as ``cv2.erode``'s default
    border). Returns the count of nonzero pixels in the other columns (the pad's are
    cleared) and their bounding box: rows [ya, yb), columns [xa, xb)."""
    h, wp = roi.shape
    size = h * wp
    src, acr, dst = roi.reshape(-1), across.reshape(-1), out.reshape(-1)
    for i in range(r):  # (pad columns: never read for the ROI's own)
        acr[i] = acr[size - 1 - i] = 0
    if r == 2:
        a, s0, s1, s2, s3, s4 = acr[2:], src[: size - 4], src[1:], src[2:], src[3:], src[4:]
        for i in range(size - 4):
            a[i] = min(min(min(s0[i], s1[i]), min(s2[i], s3[i])), s4[i])
    else:
        a, s0, s1, s2 = acr[1:], src[: size - 2], src[1:], src[2:]
        for i in range(size - 2):
            a[i] = min(min(s0[i], s1[i]), s2[i])
    if h > 2 * r:  # rows with all 2r + 1 rows of the square in the ROI
        k = r * wp
        m = size - 2 * k
        if r == 2:
            d, t0, t1, t2, t3, t4 = dst[k:], acr[:m], acr[wp:], acr[k:], acr[k + wp :], acr[2 * k :]
            for i in range(m):
                d[i] = min(min(min(t0[i], t1[i]), min(t2[i], t3[i])), t4[i])
        else:
            d, t0, t1, t2 = dst[k:], acr[:m], acr[k:], acr[2 * k :]
            for i in range(m):
                d[i] = min(min(t0[i], t1[i]), t2[i])
    for y in range(h):  # the first and last r rows: the square clipped to the ROI
        if r <= y < h - r:
            continue
        d = dst[y * wp :]
        for x in range(wp):
            d[x] = 255
        for v in range(max(y - r, 0), min(y + r + 1, h)):
            t = acr[v * wp :]
            for x in range(wp):
                d[x] = min(d[x], t[x])
    for y in range(h):
        for x in range(_PAD):
            out[y, x] = out[y, wp - 1 - x] = 0
    n = np.uint32(0)
    for i in range(size):
        n += dst[i] != 0
    if n == 0:
        return 0, 0, 0, 0, 0
    first, last = 0, size - 1
    while dst[first] == 0:
        first += 1
    while dst[last] == 0:
        last -= 1
    ya, yb = first // wp, last // wp + 1
    cols = np.zeros(wp, np.uint8)
    for y in range(ya, yb):
        row = dst[y * wp :]
        for x in range(wp):
            cols[x] = max(cols[x], row[x])
    xa, xb = wp, 0
    for x in range(wp):
        if cols[x]:
            xa, xb = min(xa, x), x + 1
    return n, ya, yb, xa, xb


@njit(cache=True)
def _belt(img, fg, xa, ya, xb, yb, out):  # pragma: no cover (compiled)
    """Free pixels of the window and, from ``_MIN_FREE`` of them, their mean colour: sums
    per column in 16 bits (at most 256 rows of 255 at a time), so they vectorise."""
    pix, free = img.reshape(-1), fg.reshape(-1)
    stride, w = img.shape[1], xb - xa
    a0, a1, a2, c = (np.zeros(w, np.uint16), np.zeros(w, np.uint16), np.zeros(w, np.uint16),
                     np.zeros(w, np.uint16))
    s0 = s1 = s2 = n = 0
    for y0 in range(ya, yb, 256):
        for y in range(y0, min(y0 + 256, yb)):
            row, f = pix[3 * (y * stride + xa) :], free[y * stride + xa :]
            for x in range(w):
                m = np.uint8(0) - np.uint8(f[x] != 255)
                a0[x] += row[3 * x] & m
                a1[x] += row[3 * x + 1] & m
                a2[x] += row[3 * x + 2] & m
                c[x] += m & 1
        for x in range(w):
            s0, s1, s2, n = s0 + a0[x], s1 + a1[x], s2 + a2[x], n + c[x]
            a0[x] = a1[x] = a2[x] = c[x] = 0
    out[_FREE] = n
    if n >= _MIN_FREE:
        scale = 1.0 / n
        out[_BELT], out[_BELT + 1], out[_BELT + 2] = s0 * scale, s1 * scale, s2 * scale


def warm_up() -> None:
    """Load (or compile, on the very first run) the kernels, on a made-up frame with one
    part, so a detector's first frame is as fast as its others."""
    img = np.full((48, 64, 3), 120, np.uint8)
    fg = np.zeros((48, 64), np.uint8)
    roi = np.zeros((30, 30), np.uint8)
    roi[5:25, 5:25] = 255
    frame_statistics(img, fg, np.array([[10, 8, 30, 30]], np.int64), roi.ravel(), 250)
    patch_statistics(img[:20, :20].copy(), np.ascontiguousarray(roi[5:25, 5:25]))
    noise_sigma(img)
    materials_from_statistics(np.ones((1, N_STATS)), np.ones((1, 3)), belt_rgb=(0.5, 0.5, 0.5),
                              noise_sigma=1.0, grain_metal=0.05, grain_z_min=3.0, albedo_sigma=0.1)
