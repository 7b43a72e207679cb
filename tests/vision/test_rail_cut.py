"""The cut of a long blob (a rail) into the parts touching it, against its definition in
OpenCV calls: the long contour's filled region (``cv2.drawContours``) and the mask, then
opened (``cv2.morphologyEx``, 3x3) and traced."""

from __future__ import annotations

import cv2
import numpy as np

from cell.vision._contours import contours
from cell.vision._segment import FrameView, _part_contours
from cell.vision.settings import VisionSettings

_K3 = np.ones((3, 3), np.uint8)


def _reference(view: FrameView, contours, hier, offset, *, cut: bool):
    """The pieces as the fill-and-AND formulation gives them."""
    for i, c in enumerate(contours):
        if len(c) < 12 or hier[i][3] != -1:
            continue
        x, y, bw, bh = cv2.boundingRect(c)
        if bw * bh < 5 or 4 * cv2.contourArea(c) < view.min_px:
            continue
        if 2 * max(bw, bh) <= view.max_px:
            yield (c + offset if offset != (0, 0) else c), (x + offset[0], y + offset[1], bw, bh)
        elif cut and min(bw, bh) >= 8:
            ox, oy = offset[0] + x, offset[1] + y
            sub = np.zeros((bh, bw), np.uint8)
            cv2.drawContours(sub, [c], -1, 255, -1, offset=(-x, -y))
            sub = cv2.bitwise_and(sub, view.mask[oy : oy + bh, ox : ox + bw])
            sub = cv2.morphologyEx(sub, cv2.MORPH_OPEN, _K3)
            cs, hr = cv2.findContours(sub, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
            if hr is not None:
                yield from _reference(view, cs, hr[0].tolist(), (ox, oy), cut=False)


def _scene(seed: int) -> np.ndarray:
    """A U-shaped rail with parts hanging off it by thin necks, a part between its arms
    (in its box, apart from it), and a hole in it holding a part-sized island."""
    rng = np.random.default_rng(seed)
    m = np.zeros((160, 320), np.uint8)
    m[20:40, 10:310] = 255  # the band
    m[40:120, 10:30] = 255  # the arms
    m[40:120, 290:310] = 255
    m[24:36, 150:170] = 0  # a hole ...
    m[27:33, 154:166] = 255  # ... with an island
    for _ in range(4):  # parts hanging off the band by a neck one or two px wide
        x, w, h = int(rng.integers(40, 240)), int(rng.integers(12, 30)), int(rng.integers(10, 25))
        m[44 : 44 + h, x : x + w] = 255
        m[40:44, x + w // 2 : x + w // 2 + int(rng.integers(1, 3))] = 255
    m[90:110, 100:130] = 255  # apart, between the arms
    m[90:110, 60:75] = 255
    m[88:92, 75:100] = 255  # touching the one above? no: a gap row and column
    m[88:92, 76:99] = 0
    noise = rng.random(m.shape) < 0.01
    m[noise] = 255 - m[noise]
    return m


def test_rail_cut_is_the_fill_and_opening_of_opencv():
    for seed in range(12):
        mask = _scene(seed)
        view = FrameView(np.zeros((*mask.shape, 3), np.uint8), np.zeros((4, 4, 3), np.uint8),
                         mask, mask, 20.0, 0, False, None, VisionSettings(), max_px=100,
                         min_px=40.0)
        cs, hr = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
        got = list(_part_contours(view, *contours(mask), (0, 0), cut=True))
        ref = list(_reference(view, cs, hr[0].tolist(), (0, 0), cut=True))
        assert len(got) == len(ref) and len(ref) >= 4
        for (a, box_a), (b, box_b) in zip(got, ref, strict=True):
            assert np.array_equal(a, b) and box_a == box_b == cv2.boundingRect(b)

