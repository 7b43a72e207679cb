"""The split stage's nearest-seed labelling against OpenCV's distance transform with
labels, the pieces it gives against OpenCV's owner-per-label masks, and their blobs
against OpenCV's contours gathered one by one (``test_blobwindows.make_blobs``)."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.vision._cutraster import nearest_labels, owned_pieces, piece_blobs
from tests.vision.test_blobwindows import assert_same_blob, make_blobs


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 50), st.integers(1, 50), st.floats(0.0005, 0.4), st.integers(0, 2**31))
def test_nearest_labels_match_opencv(h, w, density, seed):
    rng = np.random.default_rng(seed)
    src = np.where(rng.random((h, w)) < density, 0, 255).astype(np.uint8)
    src[rng.integers(h), rng.integers(w)] = 0  # at least one seed pixel
    _, expect = cv2.distanceTransformWithLabels(src, cv2.DIST_L2, 3,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    np.testing.assert_array_equal(nearest_labels(src), expect)


def test_owned_pieces_match_opencv_on_two_touching_discs():
    roi = np.zeros((40, 70), np.uint8)
    cv2.circle(roi, (20, 20), 14, 255, -1)
    cv2.circle(roi, (47, 20), 14, 255, -1)
    cv2.circle(roi, (14, 20), 3, 0, -1)  # a hole
    dist = cv2.distanceTransform(roi, cv2.DIST_L2, 3)
    n, seeds = cv2.connectedComponents((dist > 8.0).astype(np.uint8))
    assert n == 3
    seeds = seeds.astype(np.uint8)
    _, near = cv2.distanceTransformWithLabels(cv2.compare(seeds, 0, cv2.CMP_EQ), cv2.DIST_L2,
                                              3, labelType=cv2.DIST_LABEL_PIXEL)
    lookup = np.concatenate(([0], seeds[seeds != 0])).astype(np.uint8)
    owner = cv2.bitwise_and(lookup[near], roi)
    masks, counts = owned_pieces(roi, seeds)
    assert len(masks) == 2
    for lab in (1, 2):
        expect = cv2.compare(owner, lab, cv2.CMP_EQ)
        np.testing.assert_array_equal(masks[lab - 1], expect)
        assert counts[lab - 1] == cv2.countNonZero(expect)


def _reference_pieces(masks, counts, offset):
    """piece_blobs as OpenCV and make_blobs compute it, one contour at a time."""
    if counts.min() < 30:
        return None
    n, h, w = masks.shape
    contours, hr = cv2.findContours(masks.reshape(n * h, w), cv2.RETR_CCOMP,
                                    cv2.CHAIN_APPROX_NONE)
    hier = hr[0].tolist()
    outer = [-1] * n
    for i, c in enumerate(contours):
        if hier[i][3] != -1 or len(c) < 8 or cv2.contourArea(c) < 30:
            continue
        band = int(c[0, 0, 1]) // h
        if outer[band] >= 0:
            return None
        outer[band] = i
    if min(outer) < 0:
        return None
    offsets, boxes = [], []
    for band, i in enumerate(outer):
        bx, by, bw, bh = cv2.boundingRect(contours[i])
        offsets.append((offset[0], offset[1] - band * h))
        boxes.append((bx + offset[0], by - band * h + offset[1], bw, bh))
    return make_blobs(contours, hier, outer, offsets, [False] * n, boxes)


def test_piece_blobs_are_the_opencv_reference():
    found = rejected = 0
    for seed in range(60):
        rng = np.random.default_rng(seed)
        n, h, w = int(rng.integers(2, 4)), int(rng.integers(20, 60)), int(rng.integers(20, 70))
        masks = np.zeros((n, h, w), np.uint8)
        for k in range(n):
            for _ in range(int(rng.integers(1, 3))):  # sometimes two regions: rejected
                centre = (int(rng.integers(3, w - 3)), int(rng.integers(3, h - 3)))
                axes = (int(rng.integers(2, w // 2)), int(rng.integers(2, h // 2)))
                cv2.ellipse(masks[k], centre, axes, float(rng.integers(0, 180)), 0, 360, 255, -1)
            masks[k][rng.random((h, w)) < 0.02] = 0  # holes
            masks[k][[0, -1]] = 0  # the roi's blank border
            masks[k][:, [0, -1]] = 0
        counts = (masks > 0).reshape(n, -1).sum(axis=1)
        offset = (int(rng.integers(0, 300)), int(rng.integers(0, 200)))
        got, ref = piece_blobs(masks, counts, offset), _reference_pieces(masks, counts, offset)
        assert (got is None) == (ref is None)
        if ref is None:
            rejected += 1
            continue
        found += 1
        for a, b, mask in zip(got, ref, masks, strict=True):
            assert_same_blob(a, b)
            assert a.roi[:2] == offset
            np.testing.assert_array_equal(a.roi[2], mask)
    assert found > 10 and rejected > 5  # both outcomes are exercised
