"""Step 1: the belt model, the colour difference and the segmentation methods."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cell.vision.settings import SEGMENTATIONS, VisionSettings
from cell.vision.steps.foreground import belt_model, colour_difference, find_foreground
from tests.vision.steps import drawn


def test_the_belt_median_in_a_window_is_the_whole_model_resized_there():
    rng = np.random.default_rng(3)
    model = belt_model(rng.integers(0, 256, (480, 640, 3), dtype=np.uint8))
    whole = model.at((640, 480))
    for x0, y0, x1, y1 in ((0, 0, 37, 21), (100, 50, 180, 130), (601, 455, 640, 480), (8, 8, 9, 9)):
        np.testing.assert_array_equal(model.median_in(x0, y0, x1, y1), whole.median[y0:y1, x0:x1])


def test_no_difference_on_the_belt_nor_where_it_meets_the_table():
    img = drawn.frame()
    img[300:] = (150, 148, 140)  # the table below the belt's edge
    cv2.circle(img, drawn.mm(-60, 20), drawn.px(10), (200, 60, 50), -1)  # a red part
    belt = belt_model(img).at((640, 480))
    diff = colour_difference(img, belt.low, belt.high)
    assert np.percentile(diff[280:320], 99) <= 6  # the edge: within the model's range
    u, v = drawn.mm(-60, 20)
    assert diff[v, u] > 80


def test_colour_difference_is_the_largest_channel_outside_the_range():
    rng = np.random.default_rng(2)
    for shape in ((480, 640, 3), (7, 5, 3), (1, 1, 3)):
        img, low = (rng.integers(0, 256, shape, dtype=np.uint8) for _ in range(2))
        high = np.maximum(low, rng.integers(0, 256, shape, dtype=np.uint8))
        i = img.astype(int)
        want = np.maximum(np.clip(i - high, 0, None), np.clip(low - i, 0, None)).max(axis=2)
        np.testing.assert_array_equal(colour_difference(img, low, high), want)


def test_the_belt_model_ignores_the_parts():
    img = drawn.frame()
    for x in (-100, -40, 20, 80):
        cv2.circle(img, drawn.mm(x, 0), drawn.px(15), (230, 230, 230), -1)
    model = belt_model(img).at((640, 480))
    assert np.abs(model.median.astype(int) - drawn.BELT).max() <= 3


@pytest.mark.parametrize("method", SEGMENTATIONS)
def test_every_segmentation_finds_a_bright_part(method):
    img = drawn.frame()
    cv2.circle(img, drawn.mm(0, 0), drawn.px(12), (220, 220, 215), -1)
    fg = find_foreground(img, VisionSettings(segmentation=method, threshold=150))
    u, v = drawn.mm(0, 0)
    assert fg.mask[v, u] == 255 and fg.mask[10, 10] == 0
    assert cv2.countNonZero(fg.mask) == pytest.approx(np.pi * drawn.px(12) ** 2, rel=0.2)


def test_fixed_threshold_above_the_part_finds_nothing():
    img = drawn.frame()
    cv2.circle(img, drawn.mm(0, 0), drawn.px(12), (120, 120, 120), -1)
    fg = find_foreground(img, VisionSettings(segmentation="fixed", threshold=150))
    assert cv2.countNonZero(fg.mask) == 0


def test_a_light_table_is_backlit_and_parts_are_its_dark_silhouettes():
    img = np.full((480, 640, 3), 250, np.uint8)
    cv2.circle(img, drawn.mm(0, 0), drawn.px(12), (20, 20, 20), -1)
    for method in ("belt", "otsu"):
        fg = find_foreground(img, VisionSettings(segmentation=method))
        u, v = drawn.mm(0, 0)
        assert fg.backlit and fg.mask[v, u] == 255 and fg.mask[10, 10] == 0


def test_a_noisy_frame_is_smoothed_first():
    img = np.clip(drawn.frame().astype(np.float64) + np.random.default_rng(1).normal(0, 8, (480, 640, 3)),
                  0, 255).astype(np.uint8)
    fg = find_foreground(img, VisionSettings())
    assert fg.image is not img and fg.noise > 2
    assert cv2.countNonZero(fg.mask) < 0.001 * img.shape[0] * img.shape[1]  # no noise specks


def test_a_faint_rim_joins_the_clear_part_it_touches_and_faint_alone_is_belt():
    """Hysteresis: a part clear in its middle (60 grey levels over the belt) with a rim 7
    over (under the threshold, 8, over its 0.8) is one region of foreground; a region 7
    over the belt on its own is not foreground; with ``belt_low = 1`` the rim is not either."""
    img = np.empty((480, 640, 3), np.uint8)
    img[:] = drawn.BELT
    faint = tuple(c + 7 for c in drawn.BELT)
    cv2.circle(img, drawn.mm(-40, 0), drawn.px(12), faint, -1)  # the rim
    cv2.circle(img, drawn.mm(-40, 0), drawn.px(6), (200, 200, 195), -1)  # the clear middle
    cv2.rectangle(img, drawn.mm(30, 5), drawn.mm(40, -5), faint, -1)  # faint, alone
    u, v = drawn.mm(-40 + 9, 0)  # on the rim
    x, y = drawn.mm(35, 0)  # in the faint square
    fg = find_foreground(img, VisionSettings())
    assert fg.threshold == 8
    assert fg.mask[v, u] and not fg.mask[y, x]
    n, _ = cv2.connectedComponents(fg.mask)
    assert n == 2  # the part, whole, and the belt
    plain = find_foreground(img, VisionSettings(belt_low=1.0))
    assert not plain.mask[v, u] and not plain.mask[y, x]
