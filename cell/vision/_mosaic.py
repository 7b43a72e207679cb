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

from bisect import bisect_right

import numpy as np
from numba import njit

from cell.vision._segment_kernel import border, clear_shadow, lerp_rows, upper_median

__all__: list[str] = []  # private to cell.vision


class Mosaic:
    """The layout of frame windows ``boxes`` ((n, 4) int x0, y0, x1, y1; even corners;
    kept as a list) with ``ring`` px around each: their corners ``at`` ((n, 2) int64;
    also ``at_list``) in a mosaic of ``shape`` (H, W) (both even)."""

    def __init__(self, boxes: np.ndarray, ring: int) -> None:
        ring += ring & 1  # even, so that the windows sit at even places
        box_list = boxes.tolist()
        at = []
        x = ring
        for x0, _, x1, _ in box_list:
            at.append((x, ring))
            x += x1 - x0 + ((x1 - x0) & 1) + 2 * ring
        tallest = max(y1 - y0 for _, y0, _, y1 in box_list)
        self.shape = (tallest + (tallest & 1) + 2 * ring, x - ring)
        self.boxes, self.at_list, self.at = box_list, at, np.array(at, np.int64)
        self._xs = [mx for mx, _ in at]

    def window(self, a: np.ndarray, k: int) -> np.ndarray:
        """The view of mosaic-shaped array ``a`` on window ``k``."""
        mx, my = self.at_list[k]
        x0, y0, x1, y1 = self.boxes[k]
        return a[my : my + y1 - y0, mx : mx + x1 - x0]

    def which(self, x: int) -> int:
        """The window at mosaic column ``x`` (one of its columns)."""
        return bisect_right(self._xs, x) - 1


@njit(cache=True)
def refine(img, bg_small, rows, cols, boxes, at, near, level, k, edge, keep,
           fg, sub):  # pragma: no cover (compiled)
    """Refine each window ``boxes[i]`` (x0, y0, x1, y1) of ``img`` (H, W, 3) uint8 alone:

    1. the largest channel difference ``d`` of the image (box-filtered ``k`` x ``k``
       first when ``k`` > 0, rounded to nearest) from the background (``bg_small``
       resized bilinearly by tables ``rows`` (4, H), ``cols`` (4, W));
    2. its foreground: above ``level`` (float; uint8 compared with its floor), 3x3-opened,
       added (255) to ``fg`` (H, W) uint8;
    3. the window's own part: that foreground where ``near`` (the half-scale mosaic,
       uint8, 1 on the blob's filled contour), 3x3-dilated and doubled, is set;
    4. the re-threshold: ``level`` or ``edge`` times the upper median of ``d`` over the
       own part, whichever is higher, floored (at most 255);
    5. ``d`` above it near the own part (3x3-dilated), less shadow (when ``keep`` =
       1 - chroma < 1; :func:`~cell.vision._segment_kernel.clear_shadow`), 3x3-opened:
       written (1) to ``sub`` (the mosaic, zero) at ``at[i]``.
    """
    hh, ww = img.shape[:2]
    hmax, wmax = 1, 1
    for i in range(boxes.shape[0]):
        hmax = max(hmax, boxes[i, 3] - boxes[i, 1])
        wmax = max(wmax, boxes[i, 2] - boxes[i, 0])
    d = np.empty((hmax, wmax), np.uint8)
    bg = np.empty((hmax, wmax, 3), np.uint8)
    a = np.empty((hmax + 2, wmax + 2), np.uint8)  # masks with a one-pixel frame
    b = np.empty((hmax + 2, wmax + 2), np.uint8)
    tmp = np.empty((hmax + 2, wmax), np.uint8)
    hist = np.empty(256, np.int64)
    cut = np.int64(np.floor(level))
    for i in range(boxes.shape[0]):
        x0, y0, x1, y1 = boxes[i, 0], boxes[i, 1], boxes[i, 2], boxes[i, 3]
        mx, my = at[i, 0], at[i, 1]
        h, w = y1 - y0, x1 - x0
        _background(bg_small, rows, cols, x0, y0, h, w, bg)
        _difference(img, bg, x0, y0, h, w, k, d)
        for y in range(h):
            for x in range(w):
                a[y + 1, x + 1] = d[y, x] > cut
        _open3(a, b, tmp, h, w)  # -> a
        hist[:] = 0
        n = 0
        for y in range(h):
            for x in range(w):
                if a[y + 1, x + 1]:
                    fg[y0 + y, x0 + x] = 255
                    if _near(near, (my + y) // 2, (mx + x) // 2):
                        hist[d[y, x]] += 1
                        n += 1
                        continue
                a[y + 1, x + 1] = 0  # a: the own part
        again = level
        if n > 0:
            again = max(level, edge * upper_median(hist, n))
        again_cut = min(np.int64(np.floor(again)), 255)
        _frame(a, h, w, 0)
        _max3(a, b, tmp, h, w)  # b: the own part dilated
        for y in range(h):
            for x in range(w):
                b[y + 1, x + 1] = b[y + 1, x + 1] != 0 and d[y, x] > again_cut
        if keep < 1:
            clear_shadow(b[1 : h + 1, 1 : w + 1], img, bg[:h, :w], x0, y0, keep)
        _open3(b, a, tmp, h, w)  # -> b
        for y in range(h):
            for x in range(w):
                sub[my + y, mx + x] = b[y + 1, x + 1]


@njit(cache=True)
def _near(near, y, x):  # pragma: no cover (compiled)
    """Whether the 3x3 neighbourhood of ``near`` at (y, x) holds a set pixel."""
    for yy in range(max(y - 1, 0), min(y + 2, near.shape[0])):
        for xx in range(max(x - 1, 0), min(x + 2, near.shape[1])):
            if near[yy, xx]:
                return True
    return False


@njit(cache=True)
def _background(bg_small, rows, cols, x0, y0, h, w, bg):  # pragma: no cover (compiled)
    for y in range(h):
        r0, r1, b0, b1 = rows[0, y0 + y], rows[1, y0 + y], rows[2, y0 + y], rows[3, y0 + y]
        for x in range(w):
            j0, j1, a0, a1 = cols[0, x0 + x], cols[1, x0 + x], cols[2, x0 + x], cols[3, x0 + x]
            for c in range(3):
                s0 = np.int64(bg_small[r0, j0, c]) * a0 + np.int64(bg_small[r0, j1, c]) * a1
                s1 = np.int64(bg_small[r1, j0, c]) * a0 + np.int64(bg_small[r1, j1, c]) * a1
                bg[y, x, c] = lerp_rows(s0, s1, b0, b1)


@njit(cache=True)
def _difference(img, bg, x0, y0, h, w, k, d):  # pragma: no cover (compiled)
    hh, ww = img.shape[:2]
    r = k // 2
    area = max(k * k, 1)
    for y in range(h):
        for x in range(w):
            top = 0
            for c in range(3):
                if k:
                    s = 0
                    for yy in range(y0 + y - r, y0 + y + r + 1):
                        row = border(yy, hh)
                        for xx in range(x0 + x - r, x0 + x + r + 1):
                            s += img[row, border(xx, ww), c]
                    v = (2 * s + area) // (2 * area)
                else:
                    v = np.int64(img[y0 + y, x0 + x, c])
                top = max(top, abs(v - np.int64(bg[y, x, c])))
            d[y, x] = top


@njit(cache=True)
def _frame(m, h, w, value):  # pragma: no cover (compiled)
    """Set the one-pixel frame around the (h, w) window of padded mask ``m``."""
    for x in range(w + 2):
        m[0, x] = value
        m[h + 1, x] = value
    for y in range(h + 2):
        m[y, 0] = value
        m[y, w + 1] = value


@njit(cache=True)
def _min3(src, dst, tmp, h, w):  # pragma: no cover (compiled)
    for y in range(h + 2):
        for x in range(w):
            tmp[y, x] = min(min(src[y, x], src[y, x + 1]), src[y, x + 2])
    for y in range(h):
        for x in range(w):
            dst[y + 1, x + 1] = min(min(tmp[y, x], tmp[y + 1, x]), tmp[y + 2, x])


@njit(cache=True)
def _max3(src, dst, tmp, h, w):  # pragma: no cover (compiled)
    for y in range(h + 2):
        for x in range(w):
            tmp[y, x] = max(max(src[y, x], src[y, x + 1]), src[y, x + 2])
    for y in range(h):
        for x in range(w):
            dst[y + 1, x + 1] = max(max(tmp[y, x], tmp[y + 1, x]), tmp[y + 2, x])


@njit(cache=True)
def _open3(m, work, tmp, h, w):  # pragma: no cover (compiled)
    """3x3 opening of the (h, w) window of padded 0/1 mask ``m``, in place; what lies
    beyond the window counts for neither erosion nor dilation."""
    _frame(m, h, w, 1)
    _min3(m, work, tmp, h, w)
    _frame(work, h, w, 0)
    _max3(work, m, tmp, h, w)
