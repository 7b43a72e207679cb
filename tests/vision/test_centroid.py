"""The compiled pixel centroid (cell.vision._centroid) against OpenCV's polygon moments
(``cv2.moments``, as ``cell.vision._blob.px_centroid`` takes them), bit for bit."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cell.vision._blob import Blob, px_centroid
from cell.vision._centroid import _moments, blob_centroid


def _ring(rng: np.random.Generator, n: int, *, turn: float = 1.0) -> np.ndarray:
    c, r = rng.uniform(0, 640, 2), rng.uniform(0.1, 80)
    a = np.sort(rng.uniform(0, 2 * np.pi, n)) * turn
    return np.stack([c[0] + r * np.cos(a) * rng.uniform(0.5, 1, n), c[1] + r * np.sin(a)], 1)


def test_moments_equal_cv2_moments():
    """Area and first moments of random outlines (sub-pixel and half-pixel points, either
    turning sense, degenerate ones of no area) equal OpenCV's."""
    rng = np.random.default_rng(6)
    for t in range(600):
        p = _ring(rng, int(rng.integers(1, 120)), turn=1.0 if t % 2 else -1.0)
        if t % 3 == 0:
            p = np.round(p * 2) / 2
        m = cv2.moments(p.astype(np.float32))
        assert _moments(p, 0, len(p)) == (m["m00"], m["m10"], m["m01"])


@pytest.mark.parametrize("seed", range(40))
def test_blob_centroid_is_px_centroid_to_the_last_bit(seed):
    """Outlines of 3 to 300 points with up to two holes."""
    rng = np.random.default_rng(seed)
    m = int(rng.integers(3, 300))
    ang = np.sort(rng.random(m)) * 2 * math.pi
    r = 20 + 15 * rng.random(m)
    outline = np.c_[300 * rng.random() + r * np.cos(ang), 200 * rng.random() + r * np.sin(ang)]
    holes = []
    for _ in range(seed % 3):
        k = int(rng.integers(3, 40))
        t = np.sort(rng.random(k)) * 2 * math.pi
        hole = outline.mean(axis=0) + 4 * rng.random() * np.c_[np.cos(t), np.sin(t)]
        holes.append((hole, -hole))
    blob = Blob(outline, -outline, holes, (0, 0, 1, 1), False)
    assert blob_centroid(blob) == px_centroid(blob)


def test_a_blob_of_no_area_has_its_points_mean():
    line = np.c_[np.arange(5.0), np.arange(5.0)]
    blob = Blob(line, line, [], (0, 0, 5, 5), False)
    assert blob_centroid(blob) == px_centroid(blob) == (2.0, 2.0)
