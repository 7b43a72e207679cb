"""Many windows of one frame side by side in one image, a mosaic, so that one
``cv2.findContours`` call traces the outlines of all of them; and the compiled refinement
(numba) that fills that mosaic, window by window, each as if alone.

Window ``k`` of the frame (full scale, ``[y0:y1, x0:x1]``, even corners) sits in the
mosaic at ``at[k]`` = (x, y) (even), in a row, ``2 ring`` px from the next window and
``ring`` px from the mosaic's edge (``ring`` rounded up to even).

The refinement of a window (:func:`refine`) works on the frame itself: its background is
what one 8x bilinear upscaling (``cv2.resize``) of the whole 1/8-scale background gives
there, its box filter and 3x3 mean mirror the frame's edges (``BORDER_REFLECT_101``), and
its 3x3 openings (``cv2.MORPH_OPEN``) ignore what lies beyond the window, as OpenCV's
morphology ignores an image's border.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cell.vision._mask_kernel import above, and_above, frame, max3, open3
from cell.vision._segment_kernel import border, is_shadow, max_diff, upper_median
from cell.vision._smooth_kernel import box_row, gaussian_window
from cell.vision._upscale_kernel import window_background

__all__: list[str] = []  # private to cell.vision

_U = np.uint64  # (unsigned indices: no negative-index checks, so strided loops vectorise)


class Mosaic:
    """The layout of frame windows ``boxes`` (list of (x0, y0, x1, y1) ints; even
    corners) with ``ring`` px around each: their corners ``at`` ((n, 2) int64; also
    ``at_list``) in a mosaic of ``shape`` (H, W) (both even)."""

    def __init__(self, boxes: list[tuple[int, int, int, int]], ring: int) -> None:
        ring += ring & 1  # even, so that the windows sit at even places
        box_list = list(boxes)
        at = []
        x = ring
        for x0, _, x1, _ in box_list:
            at.append((x, ring))
            x += x1 - x0 + ((x1 - x0) & 1) + 2 * ring
        tallest = max(y1 - y0 for _, y0, _, y1 in box_list)
        self.shape = (tallest + (tallest & 1) + 2 * ring, x - ring)
        self.boxes, self.at_list, self.at = box_list, at, np.array(at, np.int64)

    def window(self, a: np.ndarray, k: int) -> np.ndarray:
        """The view of mosaic-shaped array ``a`` on window ``k``."""
        mx, my = self.at_list[k]
        x0, y0, x1, y1 = self.boxes[k]
        return a[my : my + y1 - y0, mx : mx + x1 - x0]


@njit(cache=True)
def refine(img, bg_small, rows, cols, boxes, at, near, level, k, taps, edge, keep,
           fg, sub):  # pragma: no cover (compiled)
    """Refine each window ``boxes[i]`` (x0, y0, x1, y1) of ``img`` (H, W, 3) uint8 alone:

    1. the largest channel difference ``d`` of the image (box-filtered ``k`` x ``k``
       first when ``k`` > 0, rounded to nearest; or by the Gaussian ``taps`` (k,)
       uint16 in 1/256 when not empty) from the background (``bg_small``
       upscaled 8x bilinearly by tables ``rows`` (4, H), ``cols`` (4, W), see
       :func:`~cell.vision._segment_kernel.upscale_axis`);
    2. its foreground: above ``level`` (float; uint8 compared with its floor), 3x3-opened,
       added (255) to ``fg`` (H, W) uint8;
    3. the window's own part: that foreground where ``near`` (the half-scale mosaic
       framed by one empty pixel, uint8, 1 on the blob's filled contour), 3x3-dilated
       and doubled, is set;
    4. the re-threshold: ``level`` or ``edge`` times the upper median of ``d`` over the
       own part, whichever is higher, floored (at most 255);
    5. ``d`` above it near the own part (3x3-dilated), less shadow (when ``keep`` =
       1 - chroma < 1; :func:`drop_shadow`), 3x3-opened:
       written (255) to ``sub`` (the mosaic, zero) at ``at[i]``.
    """
    hh, ww = img.shape[:2]
    flat = img.reshape(hh, ww * 3)
    r = k // 2
    pad = max(r, 1)  # the image around each window: the support of the filters
    hmax, wmax, small = 1, 1, 1
    for i in range(boxes.shape[0]):
        hmax = max(hmax, boxes[i, 3] - boxes[i, 1])
        wmax = max(wmax, boxes[i, 2] - boxes[i, 0])
        small = max(small, rows[1, boxes[i, 3] - 1] - rows[0, boxes[i, 1]] + 1)
    win_size = (hmax + 2 * pad) * (wmax + 2 * pad) * 3
    win_buf = np.empty(win_size, np.uint8)  # (each window with its own row length)
    sums = np.empty((wmax + 2 * pad) * 3, np.uint16)
    acc = np.empty(wmax * 3, np.uint16)
    gauss = k > 0 and taps.shape[0] > 0
    colf = np.empty(win_size if gauss else 0, np.uint16)  # (Gaussian smoothing)
    accf = np.empty(win_size if gauss else 0, np.int32)
    srcf = np.empty(win_size if gauss else 0, np.uint8)
    tp = taps.astype(np.int32)
    src = np.empty((hmax, wmax * 3), np.uint8)
    bg = np.empty((hmax, wmax * 3), np.uint8)
    inter = np.empty((small, wmax * 3), np.uint16)  # small rows interpolated along x
    cols_at, cols_weights = np.empty((2, wmax), np.uint64), np.empty((2, wmax), np.uint16)
    diff = np.empty(wmax * 3, np.uint8)
    near_win = np.empty((hmax // 2 + 1, 2 * (wmax // 2 + 1)), np.uint8)
    near_tmp = np.empty((hmax // 2 + 3, wmax // 2 + 1), np.uint8)
    size = (hmax + 2) * (wmax + 2)  # d and the masks with a one-pixel frame, each window
    d_buf, a_buf, b_buf, tmp = (np.empty(size, np.uint8), np.empty(size, np.uint8),
                                np.empty(size, np.uint8), np.empty(size, np.uint8))
    hist = np.empty(256, np.int64)
    cut = np.int64(np.floor(level))
    for i in range(boxes.shape[0]):
        x0, y0, x1, y1 = boxes[i, 0], boxes[i, 1], boxes[i, 2], boxes[i, 3]
        mx, my = at[i, 0], at[i, 1]
        h, w = y1 - y0, x1 - x0
        n_px = (h + 2) * (w + 2)  # (the window's own row length, so that the mask
        d = d_buf[:n_px].reshape((h + 2, w + 2))  # operations run over whole windows)
        a = a_buf[:n_px].reshape((h + 2, w + 2))
        b = b_buf[:n_px].reshape((h + 2, w + 2))
        wide = 3 * (w + 2 * pad)
        win = win_buf[: (h + 2 * pad) * wide].reshape((h + 2 * pad, wide))
        window(flat, x0, y0, h, w, pad, win)
        if gauss:
            gaussian_window(win_buf, wide, h, w, pad - r, tp, colf, accf, srcf)
        elif k:
            _box(win, pad - r, h, w, k, sums, acc, src)
        window_background(bg_small, rows, cols, x0, y0, h, w, inter, cols_at, cols_weights,
                          bg)
        for y in range(h):
            if gauss:
                srow = srcf[y * wide : y * wide + 3 * w]
            elif k:
                srow = src[y, : 3 * w]
            else:
                srow = win[y + pad, 3 * pad : 3 * (pad + w)]
            max_diff(srow, bg[y, : 3 * w], diff[: 3 * w], d[y + 1, 1 : w + 1])
        above(d_buf[:n_px], cut, a_buf[:n_px])  # (the frame set after)
        open3(a_buf[:n_px], b_buf[:n_px], tmp[:n_px], h, w)  # -> a
        _dilated(near, mx // 2, my // 2, (w + 1) // 2, (h + 1) // 2, near_tmp, near_win)
        hist[:] = 0
        n = 0
        for y in range(h):
            arow, frow, drow = a[y + 1, 1 : w + 1], fg[y0 + y, x0 : x0 + w], d[y + 1, 1 : w + 1]
            nrow = near_win[y // 2, :w]
            for x in range(w):
                frow[x] |= 255 * arow[x]
                arow[x] &= nrow[x]  # a: the own part
            for x in range(w):
                if arow[x]:
                    hist[drow[x]] += 1
                    n += 1
        again = level
        if n > 0:
            again = max(level, edge * upper_median(hist, n))
        again_cut = min(np.int64(np.floor(again)), 255)
        frame(a, h, w, 0)
        max3(a_buf[:n_px], b_buf[:n_px], tmp[:n_px], w + 2)  # b: the own part dilated
        and_above(d_buf[:n_px], again_cut, b_buf[:n_px])
        if keep < 1:
            drop_shadow(b, win, pad, bg, h, w, keep, sums)
        open3(b_buf[:n_px], a_buf[:n_px], tmp[:n_px], h, w)  # -> b
        for y in range(h):
            brow, out = b[y + 1, 1 : w + 1], sub[my + y, mx : mx + w]
            for x in range(w):
                out[x] = 255 * brow[x]


@njit(cache=True)
def window(flat, x0, y0, h, w, pad, win):  # pragma: no cover (compiled)
    """``win`` (h + 2 pad, 3 (w + 2 pad)): the window of image ``flat`` (H, 3 W) and
    ``pad`` px around it, mirrored past the image's edges."""
    hh, ww = flat.shape[0], flat.shape[1] // 3
    xa, xb = x0 - pad, x0 + w + pad
    lo, hi = max(xa, 0), min(xb, ww)
    for i in range(h + 2 * pad):
        row = flat[border(y0 - pad + i, hh)]
        out = win[i]
        inner, part = out[3 * (lo - xa) : 3 * (hi - xa)], row[3 * lo : 3 * hi]
        for e in range(inner.shape[0]):
            inner[e] = part[e]
        for x in range(xa, lo):
            j = 3 * border(x, ww)
            for c in range(3):
                out[3 * (x - xa) + c] = row[j + c]
        for x in range(hi, xb):
            j = 3 * border(x, ww)
            for c in range(3):
                out[3 * (x - xa) + c] = row[j + c]


@njit(cache=True)
def _box(win, o, h, w, k, sums, acc, src):  # pragma: no cover (compiled)
    """``src`` (h, 3 w): the k x k mean (rounded to nearest) of window ``win`` whose
    window pixels start ``o + k // 2`` px in; ``sums`` and ``acc`` scratch."""
    n = 3 * (w + k - 1)
    col = sums[:n]
    for y in range(h):
        first = win[y + o, 3 * o : 3 * o + n]
        for e in range(n):
            col[e] = first[e]
        for i in range(y + o + 1, y + o + k):
            row = win[i, 3 * o : 3 * o + n]
            for e in range(n):
                col[e] += row[e]
        box_row(col, k, acc[: 3 * w], src[y, : 3 * w])


@njit(cache=True)
def _dilated(near, x0, y0, w, h, tmp, out):  # pragma: no cover (compiled)
    """``out`` (h, 2 w): the 3x3 dilation of ``near`` (framed by one empty pixel) on its
    window from (x0, y0) (unframed coordinates), each pixel twice along the rows (at
    full scale); ``tmp`` scratch."""
    for y in range(h + 2):
        s0, s1, s2, t = near[y0 + y, x0 : x0 + w], near[y0 + y, x0 + 1 : x0 + w + 1], \
            near[y0 + y, x0 + 2 : x0 + w + 2], tmp[y, :w]
        for x in range(w):
            t[x] = max(max(s0[x], s1[x]), s2[x])
    for y in range(h):
        t0, t1, t2, o = tmp[y, :w], tmp[y + 1, :w], tmp[y + 2, :w], out[y, : 2 * w]
        for x in range(w):
            u = _U(x)
            o[u + u] = o[u + u + _U(1)] = max(max(t0[u], t1[u]), t2[u])


@njit(cache=True)
def drop_shadow(b, win, pad, bg, h, w, keep, sums):  # pragma: no cover (compiled)
    """Clear the shadow pixels (:func:`~cell.vision._segment_kernel.is_shadow`) of the
    (h, w) window of ``b`` (padded by one pixel), from the 3x3 mean (rounded to nearest)
    of ``win`` (the image there and ``pad`` >= 1 px around, flat (h + 2 pad, 3 (w + 2 pad)),
    from :func:`window`) and background ``bg`` (h, 3 w) uint8; ``sums`` scratch."""
    n = 3 * (w + 2)
    col = sums[:n]
    for y in range(h):
        j = 3 * (pad - 1)
        row0, row1, row2 = win[y + pad - 1, j : j + n], win[y + pad, j : j + n], win[y + pad + 1, j : j + n]
        for e in range(n):
            col[e] = np.uint16(row0[e]) + row1[e] + row2[e]
        brow, grow = b[y + 1], bg[y]
        for x in range(w):
            if brow[x + 1]:
                m0 = (2 * (np.int64(col[3 * x]) + col[3 * x + 3] + col[3 * x + 6]) + 9) // 18
                m1 = (2 * (np.int64(col[3 * x + 1]) + col[3 * x + 4] + col[3 * x + 7]) + 9) // 18
                m2 = (2 * (np.int64(col[3 * x + 2]) + col[3 * x + 5] + col[3 * x + 8]) + 9) // 18
                if is_shadow(m0, m1, m2, grow[3 * x], grow[3 * x + 1], grow[3 * x + 2], keep):
                    brow[x + 1] = 0
