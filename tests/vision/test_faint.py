"""Faint blobs: a blob that fits no kind, whose brightest tenth barely clears the
foreground threshold, is belt texture or noise; the detector drops it without searching
it for touching parts (``VisionSettings.faint_contrast``; on the bench's cached frames
this changes no detection, it only skips searches that found nothing)."""

from __future__ import annotations

import cv2
import numpy as np

import cell.vision.detector as detector_module
from cell.camera import CameraModel
from cell.vision._segment_kernel import upper_decile
from cell.vision.detector import PartDetector
from cell.vision.settings import VisionSettings


def test_upper_decile_is_the_ninetieth_percentile_of_the_half_scale_values():
    rng = np.random.default_rng(3)
    for _ in range(50):
        dmax = rng.integers(0, 256, (60, 80), dtype=np.uint8)
        h, w = int(rng.integers(1, 40)), int(rng.integers(1, 50))
        x0, y0 = int(rng.integers(0, 160 - w)), int(rng.integers(0, 120 - h))
        mask = (rng.random((h, w)) < 0.6).astype(np.uint8) * 255
        ys, xs = np.nonzero(mask)
        values = np.sort(dmax[(ys + y0) // 2, (xs + x0) // 2])
        expect = values[int(np.ceil(0.9 * len(values))) - 1] if len(values) else -1
        assert upper_decile(dmax, mask, x0, y0) == expect
    assert upper_decile(np.zeros((4, 4), np.uint8), np.zeros((2, 2), np.uint8), 0, 0) == -1


def _frame(contrast: int) -> tuple[np.ndarray, CameraModel]:
    """Two overlapping ellipses (no kind of part) ``contrast`` grey levels brighter than a
    clean, uniform belt, seen by a camera 0.4 m above the table."""
    K = np.array([[600.0, 0, 159.5], [0, 600.0, 119.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = (0.0, 0.0, 0.4)
    img = np.full((240, 320, 3), (60, 80, 110), np.uint8)
    colour = tuple(int(c) + contrast for c in (60, 80, 110))
    cv2.ellipse(img, (150, 120), (22, 9), 20.0, 0, 360, colour, -1)
    cv2.ellipse(img, (172, 126), (20, 8), 100.0, 0, 360, colour, -1)
    return img, CameraModel(320, 240, K, np.zeros(5), T)


def test_a_faint_blob_is_dropped_without_a_search(monkeypatch):
    searched = []
    split = detector_module.split_blob
    monkeypatch.setattr(detector_module, "split_blob",
                        lambda blob, view, **kw: searched.append(blob) or split(blob, view, **kw))
    faint, camera = _frame(12)  # 1.5 x the threshold (8: a clean frame's floor)
    clear, _ = _frame(60)
    for image, settings, expect in ((faint, VisionSettings(), 0),
                                    (faint, VisionSettings(faint_contrast=0.0), 1),
                                    (clear, VisionSettings(), 1)):
        detector = PartDetector(settings)  # (the first one warms its kernels up)
        searched.clear()
        detector.detect(image, camera)
        assert len(searched) == expect, (settings.faint_contrast, expect)
