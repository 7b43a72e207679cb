"""Connected-component labeling with 4- or 8-connectivity and per-region statistics.

Reference: Gonzalez & Woods, *Digital Image Processing*, 4th ed., 2.5 (adjacency,
connectivity) and 9.5; C. Grana, D. Borghesani, R. Cucchiara, "Optimized block-based
connected components labeling with decision trees", IEEE TIP 19(6), 2010. Wraps
``cv2.connectedComponentsWithStatsWithAlgorithm`` with ``cv2.CCL_GRANA`` (about 3x
faster than the default on 640x480 masks).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.vision._checks import check_choice, check_int, check_mask

__all__ = ["Components", "label_components"]


@dataclass(frozen=True, eq=False)
class Components:
    """The regions of a binary mask.

    ``labels`` is int32 (H, W): 0 is background, regions are 1..count. Per region
    ``i`` (label ``i + 1``): ``areas[i]`` pixels, ``bboxes[i]`` = (x, y, w, h) pixels
    (x right, y down; x, y of the top-left pixel), ``centroids[i]`` = (x, y) pixels.
    """

    labels: np.ndarray
    count: int
    areas: np.ndarray
    bboxes: np.ndarray
    centroids: np.ndarray

    def mask(self, label: int) -> np.ndarray:
        """The bool (H, W) mask of region ``label`` (1-based)."""
        return self.labels == label


def label_components(
    mask: np.ndarray, *, connectivity: int = 8, min_area: int = 0
) -> Components:
    """Label the connected regions of ``mask`` and measure each.

    Under 4-connectivity pixels touch only through edges; under 8-connectivity
    also through corners, so a diagonal-only chain of pixels is one region under 8
    and one region per pixel under 4.

    Parameters
    ----------
    mask : bool or uint8 (H, W); non-zero is foreground.
    connectivity : 4 or 8.
    min_area : regions smaller than this (pixels, 0 to 2**31 - 1) are dropped and the
        remaining ones renumbered 1..count in their original order.

    Returns ``Components``.
    """
    fg = check_mask("mask", mask)
    check_choice("connectivity", connectivity, (4, 8))
    min_area = check_int("min_area", min_area, 0, 2**31 - 1)
    n, labels, stats, cents = cv2.connectedComponentsWithStatsWithAlgorithm(
        fg.view(np.uint8), connectivity, cv2.CV_32S, cv2.CCL_GRANA
    )
    areas = stats[1:, cv2.CC_STAT_AREA].astype(np.int64)
    bboxes = stats[1:, :4].astype(np.int64)
    cents = cents[1:].astype(np.float64)
    if min_area > 0 and np.any(areas < min_area):
        keep = areas >= min_area
        lut = np.zeros(n, np.int32)
        lut[1:][keep] = np.arange(1, keep.sum() + 1, dtype=np.int32)
        labels = lut[labels]
        areas, bboxes, cents = areas[keep], bboxes[keep], cents[keep]
    return Components(
        labels=labels.astype(np.int32, copy=False),
        count=int(len(areas)),
        areas=areas,
        bboxes=bboxes,
        centroids=cents,
    )
