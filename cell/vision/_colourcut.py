"""Touching parts of different finishes: cut a blob along its colours.

When no straight cut between convexity defects and no distance-transform core gives
pieces that fit their kinds (:mod:`cell.vision._split`), the blob's pixels are clustered
by colour: two parts of different finishes (a red bolt on a blue nut, a grey bracket on a
red one) form two clusters in CIE Lab however their outlines meet. The interior pixels
(the blob eroded 3x3, so the outline's blend with the belt does not count) are split by
2-means (Lloyd's algorithm; the first centre is the pixel farthest from the mean, the
second the pixel farthest from the first: deterministic), lightness weighted by
``_L_WEIGHT`` so a part's shading counts less than a change of hue. Where the clusters are
apart (Fisher's ratio, the squared distance between the centres over the pooled variance
about them, at least ``_FISHER``) and each holds at least ``_MIN_SHARE`` of the pixels,
every pixel of the blob goes to the nearer centre, and each cluster's largest 8-connected
region, after a 3x3 opening (it drops the edge's blend with the belt, and keeps a square
nut's 4 px ring), seeds a piece; every pixel of the blob then goes to its nearest seed
(:func:`~cell.vision._cutraster.owned_pieces`).
Clustering for segmentation: Gonzalez & Woods, *Digital Image Processing*, 4th ed.,
sec. 10.5; Fisher's ratio: Duda, Hart & Stork, *Pattern Classification*, sec. 3.8.
"""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit

from cell.vision._mask_kernel import frame, min3, open3

__all__: list[str] = []  # private to cell.vision

# Lightness against the two colour axes: a part's own shading (raking light, a wall in
# its shadow) changes L, a change of finish mostly a and b.
_L_WEIGHT = 0.5
# Clusters this far apart (squared centre distance over the pooled variance) are two
# finishes; one finish with shading or noise stays well under it.
_FISHER = 4.0
_MIN_SHARE = 0.1  # the smaller cluster's share of the pixels, at least
_MIN_PIXELS = 60  # interior pixels needed to cluster at all
_ITERATIONS = 10


def colour_seeds(img: np.ndarray, roi: np.ndarray, ox: int, oy: int) -> np.ndarray | None:
    """Seeds (uint8, roi's shape, the two pieces' seed regions labelled 1 and 2, else 0)
    of a blob ``roi`` (uint8 (h, w), 255 inside, the blob's holes 0, a blank border of at
    least 1 px) whose top-left corner is at (``ox``, ``oy``) in the uint8 RGB frame
    ``img`` (H, W, 3); None when its colours do not fall into two clusters (see the module
    docstring), or the roi leaves the frame. After the colour conversion
    (``cv2.cvtColor``), one compiled call: the 3x3 erosion of the roi (``cv2.erode``),
    :func:`two_means` on it, every roi pixel to its nearer centre, and per cluster the
    3x3 opening (``cv2.morphologyEx``) and its largest 8-connected region (the first in
    scan order among equals, as ``cv2.connectedComponentsWithStats`` numbers them)."""
    h, w = roi.shape
    if ox < 0 or oy < 0 or ox + w > img.shape[1] or oy + h > img.shape[0]:
        return None
    lab = cv2.cvtColor(np.ascontiguousarray(img[oy : oy + h, ox : ox + w]), cv2.COLOR_RGB2LAB)
    seeds = np.zeros((h, w), np.uint8)
    if not _seeds(lab, np.ascontiguousarray(roi), _L_WEIGHT, _FISHER, _MIN_SHARE, _MIN_PIXELS,
                  _ITERATIONS, seeds):
        return None
    return seeds


@njit(cache=True)
def _seeds(lab, roi, l_weight, fisher_min, min_share, min_pixels, iterations,
           seeds):  # pragma: no cover (compiled)
    """:func:`colour_seeds` after the colour conversion: True with ``seeds`` written, or
    False. The roi's blank border is the frame of :mod:`cell.vision._mask_kernel`'s
    flat masks; every cluster pixel lies at least 2 px inside it."""
    h, w = roi.shape
    size = h * w
    mask = np.empty(size, np.uint8)
    flat = roi.reshape(-1)
    for e in range(size):
        mask[e] = flat[e] != 0
    inner = np.zeros(size, np.uint8)
    tmp = np.empty(size, np.uint8)
    min3(mask, inner, tmp, w)  # (the border is blank: no wrap-around reaches a pixel)
    centres = np.empty((2, 3))
    if not two_means(lab, inner.reshape((h, w)), l_weight, fisher_min, min_share,
                     min_pixels, iterations, centres):
        return False
    labels = np.zeros((h, w), np.uint8)  # every pixel of the blob to its nearer centre
    for y in range(h):
        for x in range(w):
            if roi[y, x] != 0:
                d0 = d1 = 0.0
                for c in range(3):
                    v = lab[y, x, c] * (l_weight if c == 0 else 1.0)
                    d0 += (v - centres[0, c]) ** 2
                    d1 += (v - centres[1, c]) ** 2
                labels[y, x] = 2 if d1 < d0 else 1
    flat_labels = labels.reshape(-1)
    for k in (1, 2):
        for e in range(size):
            mask[e] = flat_labels[e] == k
        open3(mask, inner, tmp, h - 2, w - 2)
        frame(mask.reshape((h, w)), h - 2, w - 2, 0)
        if not _largest_region(mask, w, seeds.reshape(-1), k):
            return False
    return True


@njit(cache=True)
def _largest_region(mask, w, out, value):  # pragma: no cover (compiled)
    """Write ``value`` into ``out`` on the largest 8-connected region of 0/1 ``mask``
    (flat, rows of ``w``, its first and last rows and columns 0; the first region found
    in scan order among equals); False when there is none."""
    size = mask.shape[0]
    label = np.zeros(size, np.int32)
    stack = np.empty(size, np.int64)
    steps = np.array([-w - 1, -w, -w + 1, -1, 1, w - 1, w, w + 1])
    best, best_n, n_regions = 0, 0, 0
    for e0 in range(size):
        if mask[e0] == 0 or label[e0] != 0:
            continue
        n_regions += 1
        label[e0] = n_regions
        stack[0] = e0
        top, count = 1, 0
        while top:
            top -= 1
            e = stack[top]
            count += 1
            for s in steps:
                q = e + s
                if mask[q] != 0 and label[q] == 0:
                    label[q] = n_regions
                    stack[top] = q
                    top += 1
        if count > best_n:
            best, best_n = n_regions, count
    if best == 0:
        return False
    for e in range(size):
        if label[e] == best:
            out[e] = value
    return True


@njit(cache=True)
def two_means(lab, inner, l_weight, fisher_min, min_share, min_pixels, iterations,
              centres):  # pragma: no cover (compiled)
    """Cluster the pixels of ``inner`` (uint8 (h, w), nonzero) by their colour ``lab``
    (uint8 (h, w, 3), OpenCV's 8-bit Lab; L scaled by ``l_weight``) into two (Lloyd's
    2-means, farthest-point start, at most ``iterations`` rounds); write the two centres
    into ``centres`` (2, 3) and return True when the clusters are apart (Fisher's ratio
    >= ``fisher_min``, each at least ``min_share`` of at least ``min_pixels`` pixels),
    else False (``centres`` then unspecified)."""
    h, w = inner.shape
    n = 0
    for y in range(h):
        for x in range(w):
            n += inner[y, x] != 0
    if n < min_pixels:
        return False
    pts = np.empty((n, 3))
    i = 0
    for y in range(h):
        for x in range(w):
            if inner[y, x] != 0:
                pts[i, 0] = l_weight * lab[y, x, 0]
                pts[i, 1] = lab[y, x, 1]
                pts[i, 2] = lab[y, x, 2]
                i += 1
    mean = np.zeros(3)
    for i in range(n):
        for c in range(3):
            mean[c] += pts[i, c]
    mean /= n
    centres[0] = pts[_farthest(pts, mean)]
    centres[1] = pts[_farthest(pts, centres[0])]
    lab_of = np.zeros(n, np.int64)
    sums = np.empty((2, 3))
    counts = np.empty(2, np.int64)
    for _ in range(iterations):
        sums[:] = 0.0
        counts[:] = 0
        for i in range(n):
            d0 = d1 = 0.0
            for c in range(3):
                d0 += (pts[i, c] - centres[0, c]) ** 2
                d1 += (pts[i, c] - centres[1, c]) ** 2
            k = 1 if d1 < d0 else 0
            lab_of[i] = k
            counts[k] += 1
            for c in range(3):
                sums[k, c] += pts[i, c]
        if counts[0] == 0 or counts[1] == 0:
            return False
        moved = 0.0
        for k in range(2):
            for c in range(3):
                v = sums[k, c] / counts[k]
                moved = max(moved, abs(v - centres[k, c]))
                centres[k, c] = v
        if moved < 1e-9:
            break
    if min(counts[0], counts[1]) < min_share * n:
        return False
    spread = 0.0
    for i in range(n):
        for c in range(3):
            spread += (pts[i, c] - centres[lab_of[i], c]) ** 2
    apart = 0.0
    for c in range(3):
        apart += (centres[0, c] - centres[1, c]) ** 2
    return apart >= fisher_min * max(spread / n, 1e-6)


@njit(cache=True)
def _farthest(pts, ref):  # pragma: no cover (compiled)
    """Index of the row of ``pts`` (n, 3) farthest from ``ref`` (3,) (the first of equals)."""
    best, far = 0, -1.0
    for i in range(pts.shape[0]):
        d = 0.0
        for c in range(3):
            d += (pts[i, c] - ref[c]) ** 2
        if d > far:
            best, far = i, d
    return best
