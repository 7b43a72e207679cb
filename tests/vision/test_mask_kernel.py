"""The refinement's flat 3x3 mask operations (:mod:`cell.vision._mask_kernel`) against
``cv2.morphologyEx`` (opening) and ``cv2.dilate``, with OpenCV's default borders."""

from __future__ import annotations

import cv2
import numpy as np

from cell.vision._mask_kernel import frame, max3, open3

_K3 = np.ones((3, 3), np.uint8)


def _framed(window: np.ndarray) -> np.ndarray:
    """The window laid out flat with a one-pixel frame (rows of w + 2), 0/1."""
    h, w = window.shape
    m = np.full((h + 2, w + 2), 7, np.uint8)  # (whatever the frame holds)
    m[1:-1, 1:-1] = window > 0
    return m.ravel()


def test_flat_opening_and_dilation_are_opencvs():
    rng = np.random.default_rng(3)
    for h, w in ((1, 1), (2, 5), (17, 23), (40, 9)):
        for p in (0.3, 0.6, 0.85):
            win = (rng.random((h, w)) < p).astype(np.uint8) * 255
            m = _framed(win)
            work, tmp = np.empty_like(m), np.empty_like(m)
            open3(m, work, tmp, h, w)
            opened = cv2.morphologyEx(win, cv2.MORPH_OPEN, _K3)
            np.testing.assert_array_equal(m.reshape(h + 2, w + 2)[1:-1, 1:-1] * 255, opened)
            m = _framed(win)
            frame(m.reshape(h + 2, w + 2), h, w, 0)
            out = np.empty_like(m)
            max3(m, out, tmp, w + 2)
            np.testing.assert_array_equal(out.reshape(h + 2, w + 2)[1:-1, 1:-1] * 255,
                                          cv2.dilate(win, _K3))
