"""Many windows of one frame side by side in one image, a mosaic, so that an operation
meant for each window alone runs as one OpenCV call on all of them.

Window ``k`` of the frame (full scale, ``[y0:y1, x0:x1]``, even corners) sits in the
mosaic at ``at[k]`` = (x, y) (even), in a row, ``2 ring`` px from the next window and
``ring`` px from the mosaic's edge (``ring`` rounded up to even). Its background is what one 8x bilinear
upscaling (``cv2.resize``) of the frame's 1/8-scale background blocks around all the
windows, laid side by side, gives there: exactly what upscaling the whole 1/8-scale image
would (each block keeps one small pixel around what its window needs; beyond the image,
the edge pixel repeated, as ``cv2.resize`` does there).

A 3x3 opening in the mosaic equals that opening in each window alone (whose borders do
not count for erosion nor dilation, OpenCV's default), as long as the gaps stay neutral:
full (255) while eroding, empty while dilating.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__: list[str] = []  # private to cell.vision

_S = 8  # the background's downscale factor
MAX_WINDOWS = 255  # windows in one mosaic (its label image is uint8, 255 for none)
_K3 = np.ones((3, 3), np.uint8)


class Mosaic:
    """The layout of frame windows ``boxes`` ((n, 4) int x0, y0, x1, y1; even corners;
    kept as a list) with ``ring`` px around each, their corners ``at`` ((n, 2) int; also
    ``at_list``) in the mosaic, and the background there: ``bg`` uint8 RGB (H, W, 3)
    upscaled from ``bg_small`` (uint8 RGB, the frame's background at 1/8 scale; undefined
    off the windows); ``inside`` uint8 (H, W), 255 on the windows and 0 between them
    (``outside`` the reverse); ``label`` uint8 (H, W) the window of each pixel (255
    between; at most 255 windows)."""

    def __init__(self, boxes: np.ndarray, bg_small: np.ndarray, ring: int) -> None:
        hs, ws = bg_small.shape[:2]
        ring += ring & 1  # even, so that the windows sit at even places
        padded = cv2.copyMakeBorder(bg_small, 1, 1, 1, 1, cv2.BORDER_REPLICATE)
        blocks, up_at, at = [], [], []
        width = 0
        x = ring
        box_list = boxes.tolist()
        for x0, y0, x1, y1 in box_list:
            # padded-block rows and columns: one small pixel beyond those the window samples
            i0, j0 = y0 // _S, x0 // _S
            i1, j1 = min(-(-y1 // _S) + 2, hs + 2), min(-(-x1 // _S) + 2, ws + 2)
            blocks.append(padded[i0:i1, j0:j1])
            # the small column j0 - 1 (padded j0) centres at 8 (j0 - 1) + 3.5 in the frame
            up_at.append((_S * (width - j0 + 1) + x0, _S * (1 - i0) + y0))
            width += j1 - j0
            at.append((x, ring))
            x += x1 - x0 + ((x1 - x0) & 1) + 2 * ring
        small = np.zeros((max(b.shape[0] for b in blocks), width, 3), np.uint8)
        j = 0
        for b in blocks:
            small[: b.shape[0], j : j + b.shape[1]] = b
            j += b.shape[1]
        up = cv2.resize(small, (width * _S, small.shape[0] * _S), interpolation=cv2.INTER_LINEAR)
        tallest = max(y1 - y0 for _, y0, _, y1 in box_list)
        h, w = tallest + (tallest & 1) + 2 * ring, x - ring
        self.boxes, self.at_list, self.at = box_list, at, np.array(at)
        self.bg = np.empty((h, w, 3), np.uint8)  # (only the windows are read)
        self.label = np.full((h, w), 255, np.uint8)
        for k, ((mx, my), (ux, uy), (x0, y0, x1, y1)) in enumerate(zip(at, up_at, box_list,
                                                                        strict=True)):
            self.bg[my : my + y1 - y0, mx : mx + x1 - x0] = up[uy : uy + y1 - y0, ux : ux + x1 - x0]
            self.label[my : my + y1 - y0, mx : mx + x1 - x0] = k
        self.inside = cv2.compare(self.label, 255, cv2.CMP_NE)
        self.outside = cv2.bitwise_not(self.inside)

    def window(self, a: np.ndarray, k: int, ring: int = 0) -> np.ndarray:
        """The view of mosaic-shaped array ``a`` on window ``k`` (and ``ring`` px around)."""
        mx, my = self.at_list[k]
        x0, y0, x1, y1 = self.boxes[k]
        return a[my - ring : my + y1 - y0 + ring, mx - ring : mx + x1 - x0 + ring]

    def paste(self, img: np.ndarray, ring: int) -> np.ndarray:
        """The windows of uint8 RGB frame ``img`` (H, W, 3) in a mosaic (undefined between),
        each with ``ring`` px (at most the layout's) of the frame around it, mirrored beyond
        the frame's edge (``cv2.BORDER_REFLECT_101``, as OpenCV's filters extend an image)."""
        out = np.empty(self.bg.shape, np.uint8)
        h, w = img.shape[:2]
        for k, (x0, y0, x1, y1) in enumerate(self.boxes):
            xa, ya, xb, yb = max(x0 - ring, 0), max(y0 - ring, 0), min(x1 + ring, w), min(y1 + ring, h)
            piece = img[ya:yb, xa:xb]
            if (xa, ya, xb, yb) != (x0 - ring, y0 - ring, x1 + ring, y1 + ring):
                piece = cv2.copyMakeBorder(piece, ya - y0 + ring, y1 + ring - yb,
                                           xa - x0 + ring, x1 + ring - xb, cv2.BORDER_REFLECT_101)
            self.window(out, k, ring)[...] = piece
        return out

    def open3(self, mask: np.ndarray) -> np.ndarray:
        """A 3x3 opening (``cv2.MORPH_OPEN``) of each window of uint8 ``mask`` (zero
        between windows) on its own; zero between windows."""
        eroded = cv2.bitwise_and(cv2.erode(cv2.bitwise_or(mask, self.outside), _K3), self.inside)
        return cv2.bitwise_and(cv2.dilate(eroded, _K3), self.inside)

    def medians(self, a: np.ndarray, where: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(upper median, count) of uint8 mosaic ``a`` over each window's pixels where
        uint8 ``where`` is nonzero (as ``np.partition(v, len(v) // 2)``; 0 where none),
        from one histogram of (window, value) pairs (``cv2.calcHist``)."""
        n = len(self.boxes)
        hist = cv2.calcHist([self.label, a], [0, 1], where, [n, 256], [0, n, 0, 256])
        cum = np.cumsum(hist.astype(np.int64), axis=1)
        count = cum[:, -1]
        return np.count_nonzero(cum <= (count // 2)[:, None], axis=1), count
