"""The compiled border following (:func:`cell.vision._contours.contours`) against
``cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)``: the same points, in
the same order, with the same hierarchy, on masks of every kind (specks, ragged blobs
with holes and islands, shapes touching the image's edge, more than 127 borders so that
the labels wrap)."""

from __future__ import annotations

import cv2
import numpy as np

from cell.vision._contours import contours, opened_contours


def _assert_opencvs(mask: np.ndarray) -> int:
    cs, hier = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    pts, starts, hr = contours(mask)
    if hier is None:
        assert len(hr) == 0 and len(pts) == 0 and starts.tolist() == [0]
        return 0
    np.testing.assert_array_equal(hr, hier[0])
    np.testing.assert_array_equal(starts, np.cumsum([0] + [len(c) for c in cs]))
    np.testing.assert_array_equal(pts, np.concatenate(cs).reshape(-1, 2))
    return len(cs)


def test_noise_masks_are_traced_as_opencv_does():
    rng = np.random.default_rng(0)
    for trial in range(600):
        h, w = (int(v) for v in rng.integers(1, 60, 2))
        mask = ((rng.random((h, w)) < rng.random()) * int(rng.choice([1, 255]))).astype(np.uint8)
        if trial % 3 == 0:
            mask = cv2.dilate(mask, None)
        _assert_opencvs(mask)


def test_blob_masks_are_traced_as_opencv_does():
    rng = np.random.default_rng(1)
    most = 0
    for _ in range(60):
        h, w = (int(v) for v in rng.integers(20, 300, 2))
        field = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0),
                                 float(rng.uniform(0.5, 4)))
        mask = (field > np.quantile(field, rng.uniform(0.2, 0.8))).astype(np.uint8) * 255
        most = max(most, _assert_opencvs(mask))
    assert most > 300  # (labels wrapped: borders told apart by following them again)


def test_edge_cases():
    for mask in (np.zeros((5, 7), np.uint8), np.full((5, 7), 255, np.uint8),
                 np.full((1, 9), 255, np.uint8), np.full((9, 1), 255, np.uint8),
                 np.eye(6, dtype=np.uint8), np.pad(np.ones((3, 3), np.uint8), 2)):
        _assert_opencvs(mask)


def test_opened_masks_are_traced_as_opencv_does():
    rng = np.random.default_rng(2)
    k3 = np.ones((3, 3), np.uint8)
    for _ in range(200):
        h, w = (int(v) for v in rng.integers(1, 80, 2))
        field = cv2.GaussianBlur(rng.random((h + 6, w + 6)).astype(np.float32), (0, 0), 1.0)
        mask = (field > np.quantile(field, rng.uniform(0.2, 0.8))).astype(np.uint8) * 255
        box = mask[3 : 3 + h, 2 : 2 + w]  # (a box of a larger mask, as the cut takes)
        cs, hier = cv2.findContours(cv2.morphologyEx(box, cv2.MORPH_OPEN, k3), cv2.RETR_CCOMP,
                                    cv2.CHAIN_APPROX_NONE)
        pts, starts, hr = opened_contours(mask, 2, 3, w, h)
        if hier is None:
            assert len(hr) == 0
            continue
        np.testing.assert_array_equal(hr, hier[0])
        np.testing.assert_array_equal(starts, np.cumsum([0] + [len(c) for c in cs]))
        np.testing.assert_array_equal(pts, np.concatenate(cs).reshape(-1, 2))
