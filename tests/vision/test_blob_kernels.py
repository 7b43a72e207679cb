"""The compiled contour pass of :mod:`cell.vision._blob` against its reference: the
outlines and normals of many contours at once (:func:`~cell.vision._blob.outline_normals`)."""

from __future__ import annotations

import cv2
import numpy as np

from cell.vision._blob import _normals, outline_normals


def _contours(seed: int):
    rng = np.random.default_rng(seed)
    mask = np.zeros((120, 160), np.uint8)
    for _ in range(12):
        x, y = int(rng.integers(0, 150)), int(rng.integers(0, 110))
        w, h = int(rng.integers(1, 30)), int(rng.integers(1, 30))
        cv2.ellipse(mask, (x, y), (w, h), float(rng.integers(0, 180)), 0, 360, 255, -1)
    mask[rng.random(mask.shape) < 0.02] = 0  # holes, and ragged edges
    mask[rng.random(mask.shape) < 0.005] = 255  # specks of 1 point
    cs, hier = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    return cs, hier[0]


def test_normals_of_many_contours_are_those_of_each():
    for seed in range(4):
        cs, hier = _contours(seed)
        holes = [int(h[3] != -1) for h in hier]
        shifts = [(3 * i - 7, 11 - 2 * i) for i in range(len(cs))]
        meta = np.array([(len(c), hole, sx, sy)
                         for c, hole, (sx, sy) in zip(cs, holes, shifts, strict=True)], np.int64)
        n = int(meta[:, 0].sum())
        out, nrm = np.empty((n, 2)), np.empty((n, 2))
        _normals(np.concatenate(cs).reshape(-1, 2), meta, out, nrm)
        start = 0
        for c, hole, shift in zip(cs, holes, shifts, strict=True):
            ref_out, ref_n = outline_normals(c.reshape(-1, 2) + shift, hole=bool(hole))
            k = len(c)
            np.testing.assert_allclose(nrm[start : start + k], ref_n, rtol=0, atol=1e-12)
            np.testing.assert_allclose(out[start : start + k], ref_out, rtol=0, atol=1e-12)
            start += k
