"""The compiled choice of half-scale contours that may be parts
(:func:`~cell.vision._segment_kernel.outer_boxes`) against OpenCV's ``boundingRect`` and
``contourArea``, one contour at a time."""

from __future__ import annotations

import cv2
import numpy as np

from cell.vision._segment_kernel import outer_boxes


def _reference(cs, hier, min_px, max_px):
    rows = []
    for i, c in enumerate(cs):
        if len(c) < 12 or hier[i][3] != -1:
            continue
        x, y, w, h = cv2.boundingRect(c)
        if w * h < 5 or 4 * cv2.contourArea(c) < min_px:
            continue
        if 2 * max(w, h) <= max_px:
            rows.append([i, x, y, w, h, 0])
        elif min(w, h) >= 8:
            rows.append([i, x, y, w, h, 1])
    return rows


def test_outer_boxes_are_opencvs_choice():
    kinds = set()
    for seed in range(30):
        rng = np.random.default_rng(seed)
        mask = np.zeros((240, 320), np.uint8)
        for _ in range(15):
            centre = (int(rng.integers(0, 320)), int(rng.integers(0, 240)))
            axes = (int(rng.integers(1, 30)), int(rng.integers(1, 20)))
            cv2.ellipse(mask, centre, axes, float(rng.integers(0, 180)), 0, 360, 255, -1)
        y = int(rng.integers(0, 230))
        mask[y : y + int(rng.integers(1, 12)), :] = 255  # a rail, thick or thin
        mask[rng.random(mask.shape) < 0.01] = 0
        cs, hier = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
        lengths = np.array([len(c) for c in cs], np.int64)
        for min_px, max_px in ((40.0, 150), (300.0, 90)):
            got = outer_boxes(np.concatenate(cs).reshape(-1, 2), lengths, hier[0], min_px,
                              max_px).tolist()
            assert got == _reference(cs, hier[0].tolist(), min_px, max_px)
            kinds.update(r[5] for r in got)
    assert kinds == {0, 1}
