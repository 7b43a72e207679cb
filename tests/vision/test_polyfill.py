"""The compiled fill of a split piece's outline within its parent's mask
(cell.vision._polyfill) against ``cv2.fillPoly`` and ``cv2.bitwise_and``, pixel for pixel."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cell.vision._polyfill import fill_within


def _polygon(rng: np.random.Generator, mode: int, w: int, h: int) -> np.ndarray:
    """Integer points inside a (w, h) box: anywhere (self-intersecting), a walk of unit
    or longer steps, or a star around the middle."""
    n = int(rng.integers(3, 120))
    if mode == 0:
        pts = np.c_[rng.integers(0, w, n), rng.integers(0, h, n)]
    elif mode in (1, 2):
        reach = 1 if mode == 1 else 3
        pts = np.cumsum(rng.integers(-reach, reach + 1, (n, 2)), 0) + [w // 2, h // 2]
    else:
        a = np.sort(rng.uniform(0, 2 * np.pi, n))
        r = rng.uniform(0.2, 0.5, n) * min(w, h)
        pts = np.round(np.c_[w / 2 + r * np.cos(a), h / 2 + r * np.sin(a)])
    return np.clip(pts, 0, [w - 1, h - 1]).astype(np.int32)


@pytest.mark.parametrize("seed", range(8))
def test_fill_within_is_fillpoly_and_mask(seed):
    """Random outlines (pixel centres given as half-pixel-shifted points with their
    normals) in a random mask at a random frame offset."""
    rng = np.random.default_rng(seed)
    for t in range(500):
        w, h = (int(v) for v in rng.integers(5, 80, 2))
        pts = _polygon(rng, t % 4, w, h)
        x0, y0 = (int(v) for v in rng.integers(-5, 50, 2))
        mask = np.where(rng.random((h, w)) < 0.8, rng.integers(1, 256), 0).astype(np.uint8)
        ref = np.zeros_like(mask)
        cv2.fillPoly(ref, [pts + [x0, y0]], 255, offset=(-x0, -y0))
        ref = cv2.bitwise_and(ref, mask)
        normals = rng.normal(size=(len(pts), 2))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        contour = pts + [x0, y0] + 0.5 * normals
        ok, own = fill_within(mask, contour, normals, x0, y0)
        assert ok
        assert np.array_equal(own, ref)


def test_an_outline_leaving_the_mask_is_left_to_opencv():
    mask = np.full((10, 10), 255, np.uint8)
    pts = np.array([[2.0, 2.0], [12.0, 3.0], [4.0, 8.0]])
    ok, own = fill_within(mask, pts, np.zeros_like(pts), 0, 0)
    assert not ok and own.size == 0
