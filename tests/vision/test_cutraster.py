"""The split stage's nearest-seed labelling against OpenCV's distance transform with
labels, and the pieces it gives against OpenCV's owner-per-label masks."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.vision._cutraster import nearest_labels, owned_pieces


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
