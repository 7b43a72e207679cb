"""Material of every part in a frame at once, from each part's own pixels.

Per part: the interior, away from the edge's blend with the belt (a 5x5 erosion of its
mask ``Blob.roi``, or 3x3 where that leaves fewer than 150 pixels: a square nut's ring is
4 px wide), and the belt's colour next to it, which white-balances its albedo (a part
seen against a glowing light table is a silhouette: ``unknown``).

Then all parts at once: each interior's bounding box and ``SUPPORT`` px around it (within
the ROI) is laid out one below the other in a mosaic, each patch mirrored into a frame of
``SUPPORT`` px (``cv2.BORDER_REFLECT_101``, as a filter sees a patch by itself), so the
features' filters (:func:`cell.vision.material.mosaic_features`) run once per frame and
give at each interior pixel what they give on that part's patch alone.
"""

from __future__ import annotations

from itertools import accumulate

import cv2
import numpy as np

from cell.vision._blob import Blob
from cell.vision._segment import FrameView
from cell.vision.material import SUPPORT, classify_materials, mosaic_features

__all__: list[str] = []  # private to cell.vision

_K3 = np.ones((3, 3), np.uint8)
_K5 = np.ones((5, 5), np.uint8)
_UNKNOWN = ("unknown", 0.0)


def part_materials(view: FrameView, blobs: list[Blob]) -> list[tuple[str, float]]:
    """(material, confidence) of each blob, from its ROI's interior (see the module
    docstring); ``unknown`` for a back-lit frame, a blob without ROI, an interior under 8
    pixels, or a part on a light table."""
    out = [_UNKNOWN] * len(blobs)
    if view.backlit:
        return out
    st = view.settings
    found, patches, masks, counts, belts = [], [], [], [], []
    for i, blob in enumerate(blobs):
        if blob.roi is None:
            continue
        x0, y0, roi = blob.roi
        sel = cv2.erode(roi, _K5)
        n = cv2.countNonZero(sel)
        if n < 150:
            sel = cv2.erode(roi, _K3)
            n = cv2.countNonZero(sel)
            if n < 8:
                continue
        h, w = roi.shape
        belt = _belt_near(view, x0, y0, x0 + w, y0 + h)
        if min(belt.tolist()) >= st.backlight_level:
            continue  # a glowing light table behind this part: a silhouette
        # Only the interior's bounding box and SUPPORT px around it (within the ROI):
        # the same features, on fewer pixels.
        bx, by, bw, bh = cv2.boundingRect(sel)
        xa, ya = max(bx - SUPPORT, 0), max(by - SUPPORT, 0)
        xb, yb = min(bx + bw + SUPPORT, w), min(by + bh + SUPPORT, h)
        found.append(i)
        patches.append(view.img[y0 + ya : y0 + yb, x0 + xa : x0 + xb])
        masks.append(sel[ya:yb, xa:xb])
        counts.append(n)
        belts.append(belt)
    if not found:
        return out
    mosaic, at = _mosaic(patches, masks)
    feats = mosaic_features(mosaic, at, counts, np.array(belts), belt_rgb=st.belt_rgb,
                            noise_sigma=view.noise_sigma())
    labels = classify_materials(feats, backlit=False, grain_metal=st.grain_metal,
                                grain_z_min=st.grain_z_min, albedo_sigma=st.albedo_sigma)
    for i, label in zip(found, labels, strict=True):
        out[i] = label
    return out


def _mosaic(patches: list[np.ndarray], masks: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The patches (uint8 (h, w, 3) each) one below the other, each mirrored SUPPORT px
    into a frame around it (``cv2.BORDER_REFLECT_101``), and the flat indices of their
    masks' (uint8 (h, w)) nonzero pixels there, patch after patch, each in row-major order."""
    p = SUPPORT
    tops = list(accumulate((m.shape[0] + 2 * p for m in masks), initial=0))
    width = max(m.shape[1] for m in masks) + 2 * p
    mosaic = np.zeros((tops[-1], width, 3), np.uint8)
    inside = np.zeros((tops[-1], width), bool)  # (np.flatnonzero is fastest on bool)
    for patch, mask, top in zip(patches, masks, tops, strict=False):
        h, w = mask.shape
        cv2.copyMakeBorder(patch, p, p, p, p, cv2.BORDER_REFLECT_101,
                           dst=mosaic[top : top + h + 2 * p, : w + 2 * p])
        inside[top + p : top + p + h, p : p + w] = mask
    return mosaic, np.flatnonzero(inside)


def _belt_near(view: FrameView, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    """The belt's colour next to a part: the mean of the background pixels in a window
    around it (the median-filtered estimate is biased near a part in a noisy frame)."""
    h, w = view.fg.shape
    xa, ya, xb, yb = max(x0 - 6, 0), max(y0 - 6, 0), min(x1 + 6, w), min(y1 + 6, h)
    free = cv2.bitwise_not(view.fg[ya:yb, xa:xb])
    if cv2.countNonZero(free) < 30:
        u, v = min((x0 + x1) // 2, w - 1), min((y0 + y1) // 2, h - 1)
        return view.background_at(u, v, u + 1, v + 1)[0, 0]
    return np.array(cv2.mean(view.img[ya:yb, xa:xb], mask=free)[:3])
