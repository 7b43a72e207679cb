"""What :func:`cell.vision._segment._refine` relies on when it draws every blob's filled
half-scale region into its window of the mosaic in one ``cv2.drawContours`` call: that
equals drawing them one by one (the windows lie side by side, apart)."""

from __future__ import annotations

import cv2
import numpy as np


def test_one_filled_draw_of_contours_in_separate_windows_is_one_draw_each():
    for seed in range(40):
        rng = np.random.default_rng(seed)
        shifted, x = [], 1
        for _ in range(int(rng.integers(1, 9))):
            w, h = int(rng.integers(6, 60)), int(rng.integers(6, 50))
            blob = np.zeros((h, w), np.uint8)
            for _ in range(int(rng.integers(1, 4))):
                centre = (int(rng.integers(0, w)), int(rng.integers(0, h)))
                axes = (int(rng.integers(1, w)), int(rng.integers(1, h)))
                cv2.ellipse(blob, centre, axes, float(rng.integers(0, 180)), 0, 360, 255, -1)
            blob[rng.random(blob.shape) < 0.05] = 0  # ragged: concave outlines, holes
            cs, _ = cv2.findContours(blob, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
            shifted.append(max(cs, key=len) + (x, 1))
            x += w + 2 * int(rng.integers(1, 4))  # the next window, a ring apart
        one = np.zeros((52, x + 1), np.uint8)
        cv2.drawContours(one, shifted, -1, 1, -1)
        each = np.zeros_like(one)
        for c in shifted:
            cv2.drawContours(each, [c], 0, 1, -1)
        np.testing.assert_array_equal(one, each)
