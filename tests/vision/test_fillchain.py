"""The compiled fill of pixel chains (:func:`cell.vision._fillchain.fill_chains`) against
``cv2.drawContours(..., -1, value, cv2.FILLED)`` pixel for pixel: ragged blobs with
holes, thin lines and single pixels, each contour moved into its own window as the
refinement lays them out."""

from __future__ import annotations

import cv2
import numpy as np

from cell.vision._contours import contours
from cell.vision._fillchain import fill_chains


def test_chains_fill_as_opencv_draws_them():
    rng = np.random.default_rng(0)
    filled = 0
    for trial in range(160):
        h, w = (int(v) for v in rng.integers(10, 120, 2))
        field = rng.random((h, w)).astype(np.float32)
        if trial % 2:  # (else noise: specks, lines, diagonal bridges)
            field = cv2.GaussianBlur(field, (0, 0), float(rng.uniform(0.3, 3)))
        mask = (field > np.quantile(field, rng.uniform(0.3, 0.9))).astype(np.uint8)
        pts, starts, hier = contours(mask)
        outer = [i for i in range(len(hier)) if hier[i, 3] == -1]
        chains = [pts[starts[i] : starts[i + 1]] for i in outer]
        shifts = np.array([(k * (w + 3) + 1, 2) for k in range(len(chains))], np.int64)
        ref = np.zeros((h + 4, len(chains) * (w + 3) + 2), np.uint8)
        cv2.drawContours(ref, [c + s.astype(np.int32) for c, s in zip(chains, shifts, strict=True)],
                         -1, 1, -1)
        got = np.zeros_like(ref)
        joined = np.concatenate(chains) if chains else np.empty((0, 2), np.int32)
        bounds = np.cumsum([0] + [len(c) for c in chains]).astype(np.int64)
        fill_chains(got, joined, bounds, shifts, 1)
        np.testing.assert_array_equal(got, ref)
        filled += int(ref.sum())
    assert filled > 10000
