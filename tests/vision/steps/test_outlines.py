"""Step 2: outlines on the region's edge, normals, shadows, one outline per region."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cell.vision.settings import VisionSettings
from cell.vision.steps.foreground import find_foreground
from cell.vision.steps.outlines import find_outlines, outline_of_mask, ring, shadow
from tests.vision.steps import drawn


def test_normals_point_out_of_the_region_and_into_holes():
    mask = np.zeros((60, 60), np.uint8)
    cv2.rectangle(mask, (10, 10), (49, 49), 255, -1)
    cv2.rectangle(mask, (25, 25), (34, 34), 0, -1)
    (blob,) = outline_of_mask(mask, 100, 200, frame=(640, 480))
    centre = np.array([129.5, 229.5])
    assert np.all(np.einsum("ij,ij->i", blob.outer.normals, blob.outer.points - centre) > 0)
    (hole,) = blob.holes
    assert np.all(np.einsum("ij,ij->i", hole.normals, hole.points - centre) < 0)
    area = cv2.contourArea(blob.outer.points.astype(np.float32)) - cv2.contourArea(
        hole.points.astype(np.float32))
    assert area == pytest.approx(cv2.countNonZero(mask), rel=0.02)  # on the region's edge
    assert blob.area == cv2.countNonZero(mask)
    assert (blob.pixels.x0, blob.pixels.y0, blob.pixels.mask.shape) == (110, 210, (40, 40))
    assert not blob.partial


def test_normals_are_the_turned_five_point_tangents():
    t = np.linspace(0, 2 * np.pi, 23, endpoint=False)
    pts = np.round(np.stack([50 + 20 * np.cos(t), 40 + 12 * np.sin(t)], 1)).astype(np.int32)
    for p, hole in ((pts, False), (pts[::-1], False), (pts, True)):
        r = ring(p.reshape(-1, 1, 2), hole=hole)
        q = p.astype(np.float64)
        tan = np.roll(q, -2, axis=0) - np.roll(q, 2, axis=0)
        ref = np.stack([tan[:, 1], -tan[:, 0]], 1) / np.hypot(tan[:, 0], tan[:, 1])[:, None]
        if (np.einsum("ij,ij->i", ref, q - q.mean(axis=0)) > 0).mean() < 0.5:
            ref = -ref
        np.testing.assert_allclose(r.normals, -ref if hole else ref, atol=1e-12)
        np.testing.assert_allclose(r.points, q + 0.5 * r.normals, atol=1e-12)


def test_shadow_is_the_belt_darker_by_one_factor_not_a_dark_part():
    belt = np.full((40, 60, 3), (60, 80, 110), np.uint8)
    img = belt.copy()
    img[:, :20] = (30, 40, 55)  # the belt at half the light: shadow
    img[:, 20:40] = (20, 20, 20)  # a black part: darker, but not the belt's colour
    img[:, 40:] = (120, 160, 220)  # the belt at twice the light: a pool of light
    out = shadow(img, belt, chroma=0.25)
    assert out[5:35, 2:18].all() and not out[:, 22:38].any() and out[5:35, 42:58].all()
    assert not shadow(img, belt, chroma=0.25, noise=20.0).any()  # too noisy to tell


def test_a_part_in_the_hole_of_another_blob_is_its_own_outline_once():
    img = drawn.frame()
    cv2.rectangle(img, drawn.mm(-30, 30), drawn.mm(30, -30), (200, 200, 195), -1)
    cv2.rectangle(img, drawn.mm(-20, 20), drawn.mm(20, -20), drawn.BELT, -1)
    cv2.circle(img, drawn.mm(0, 0), drawn.px(8), (210, 60, 50), -1)
    fg = find_foreground(img, VisionSettings())
    blobs = find_outlines(fg, VisionSettings(), min_px=50, max_px=180)
    assert len(blobs) == 2
    disc = min(blobs, key=lambda b: b.area)
    assert disc.centroid == pytest.approx(drawn.mm(0, 0), abs=0.5)
    assert disc.area == pytest.approx(np.pi * drawn.px(8) ** 2, rel=0.1)


def test_a_rail_is_left_out_and_a_part_touching_it_kept():
    img = drawn.frame()
    img[100:106] = (170, 170, 170)  # a rail across the whole view
    cv2.circle(img, (300, 120), 18, (200, 60, 50), -1)  # touching it from below
    fg = find_foreground(img, VisionSettings())
    blobs = find_outlines(fg, VisionSettings(), min_px=50, max_px=180)
    assert len(blobs) == 1
    assert blobs[0].centroid == pytest.approx((300, 121), abs=2.0)


def test_a_part_inside_a_rails_box_is_not_taken_with_the_rail():
    """A rail with a spur (a shadow joined to it) spans a box that reaches over a part
    lying apart from it: the part is one outline, not cut at the edge of that box."""
    img = drawn.frame()
    img[300:306] = (170, 170, 170)  # a rail across the whole view
    img[240:300, 100:110] = (170, 170, 170)  # a spur rising from it, up to row 240
    cv2.circle(img, (300, 240), 18, (200, 60, 50), -1)  # apart, across row 240
    fg = find_foreground(img, VisionSettings())
    blobs = [b for b in find_outlines(fg, VisionSettings(), min_px=50, max_px=180)
             if b.centroid[0] > 200]
    assert len(blobs) == 1
    assert blobs[0].centroid == pytest.approx((300, 240), abs=1.0)
    assert blobs[0].area == pytest.approx(np.pi * 18 ** 2, rel=0.1)


def test_a_region_within_margin_of_the_bottom_or_right_border_is_partial():
    """margin 1 in a 64 x 48 frame: a region whose last row is 46 (one short of the
    border row 47) is partial, like one whose last column is 62; one row or column
    farther in is whole."""
    def partial(x, y, w, h):
        mask = np.zeros((48, 64), np.uint8)
        mask[y:y + h, x:x + w] = 255
        (o,) = outline_of_mask(mask, 0, 0, frame=(64, 48), margin=1)
        return o.partial

    assert partial(20, 37, 10, 10)  # rows 37..46
    assert partial(53, 20, 10, 10)  # columns 53..62
    assert not partial(20, 36, 10, 10)  # rows 36..45
    assert not partial(52, 20, 10, 10)  # columns 52..61


def test_is_faint_reads_the_brightest_tenth_against_the_threshold():
    """A region is faint when its brightest tenth stands under ``contrast`` thresholds
    from the belt: a smudge 12 grey levels over it is (threshold 8: 1.5 of it), a light
    grey part is not; a contrast of 0 calls nothing faint."""
    import cv2

    from cell.vision.settings import VisionSettings
    from cell.vision.steps.foreground import find_foreground
    from cell.vision.steps.outlines import find_outlines, is_faint
    from tests.vision.steps import drawn

    img = drawn.frame()
    cv2.circle(img, drawn.mm(-60, 0), drawn.px(15), tuple(int(c) + 12 for c in drawn.BELT), -1)
    cv2.circle(img, drawn.mm(60, 0), drawn.px(15), (200, 200, 195), -1)
    fg = find_foreground(img, VisionSettings())
    assert fg.threshold == 8.0
    dim, bright = sorted(find_outlines(fg, VisionSettings(), min_px=50, max_px=180),
                         key=lambda b: b.centroid[0])
    assert is_faint(dim.pixels, fg, 1.85) and not is_faint(bright.pixels, fg, 1.85)
    assert not is_faint(dim.pixels, fg, 1.4)  # it stands 1.5 thresholds out
    assert not is_faint(dim.pixels, fg, 0.0)
