import math

import cv2
import numpy as np
import pytest

from cell.catalogue import KINDS
from cell.errors import VisionError
from cell.vision.labeling import label_components
from cell.vision.shape import (
    aspect_ratio,
    circularity,
    compactness,
    count_holes,
    describe_shape,
    hu_moments,
    orientation,
    perimeter,
)
from cell.vision.smoothing import median
from cell.vision.threshold import threshold_otsu

PX_PER_MM = 1.65  # the overhead camera at 0.40 m, fovy 40 deg, 640x480


def _draw(fn, shape=(120, 160), ss=4):
    """Anti-aliased synthetic mask: draw at ``ss`` x scale, area-average, threshold 0.5."""
    big = np.zeros((shape[0] * ss, shape[1] * ss), np.uint8)
    fn(big, ss)
    return cv2.resize(big, shape[::-1], interpolation=cv2.INTER_AREA) > 127


def _washer(img, ss):
    r_out = KINDS["washer"].length / 2 * 1000 * PX_PER_MM * ss
    r_in = KINDS["washer"].hole / 2 * 1000 * PX_PER_MM * ss
    c = (80 * ss, 60 * ss)
    cv2.circle(img, c, round(r_out), 255, -1)
    cv2.circle(img, c, round(r_in), 0, -1)


def _box(kind, angle_deg, hole=True):
    def fn(img, ss):
        k = KINDS[kind]
        size = (k.length * 1000 * PX_PER_MM * ss, k.width * 1000 * PX_PER_MM * ss)
        pts = cv2.boxPoints(((80 * ss, 60 * ss), size, angle_deg))
        cv2.fillConvexPoly(img, np.rint(pts).astype(np.int32), 255)
        if hole and k.hole:
            cv2.circle(img, (80 * ss, 60 * ss), round(k.hole / 2 * 1000 * PX_PER_MM * ss), 0, -1)
    return fn


def test_synthetic_parts_at_catalogue_size():
    washer = describe_shape(_draw(_washer))
    assert abs(washer.circularity - 1) < 0.1 and washer.holes == 1
    nut = describe_shape(_draw(_box("square_nut", 20)))
    assert nut.circularity > washer.circularity + 0.15 and nut.holes == 1
    bolt = describe_shape(_draw(_box("bolt", 30)))
    assert bolt.aspect_ratio > 3 and bolt.holes == 0
    assert abs(math.degrees(bolt.orientation) - 30) < 1.0
    assert abs(math.degrees(bolt.rect_angle) - 30) < 1.5


def test_descriptors_of_a_rectangle_match_hand_computed_values():
    mask = np.zeros((50, 60), bool)
    mask[10:20, 10:50] = True  # 40 x 10 px
    assert mask.sum() == 400
    # boundary chain through pixel centres: 2 * (39 + 9)
    assert perimeter(mask) == pytest.approx(96.0)
    assert aspect_ratio(mask) == pytest.approx(4.0)
    assert circularity(mask) == pytest.approx(96**2 / (4 * math.pi * 400))
    assert compactness(mask) == pytest.approx(400 / 96**2)
    assert orientation(mask) == pytest.approx(0.0, abs=1e-9)
    assert orientation(mask.T) == pytest.approx(math.pi / 2)
    assert count_holes(mask) == 0


def test_hu_moments_are_rotation_invariant():
    a = hu_moments(_draw(_box("bolt", 0, hole=False)))
    b = hu_moments(_draw(_box("bolt", 37, hole=False)))
    w = hu_moments(_draw(_washer))
    np.testing.assert_allclose(a[:2], b[:2], rtol=0.1)
    np.testing.assert_allclose(a[2:], b[2:], atol=1e-5)
    assert abs(a[1] - w[1]) > 10 * abs(a[1] - b[1])  # and they tell a washer from a bolt


def test_orientation_matches_fitted_ellipse():
    mask = _draw(_box("bolt", -55, hole=False))
    pts = np.argwhere(mask)[:, ::-1].astype(np.float32)
    (_, _), (_, _), ang = cv2.fitEllipse(pts)  # ellipse angle: its first axis
    theta = math.degrees(orientation(mask))
    assert min(abs(theta - (ang - 90)) % 180, 180 - abs(theta - (ang - 90)) % 180) < 1.0


def test_holes_count_every_enclosed_background_region():
    mask = np.ones((40, 40), bool)
    mask[5:10, 5:10] = False
    mask[20:25, 20:30] = False
    mask[30, 30] = False  # a one-pixel pinhole, ignored by describe_shape's default
    assert count_holes(mask) == 3
    assert describe_shape(mask).holes == 2


@pytest.fixture(scope="module")
def rendered_silhouettes():
    """Back-lit overhead renders: two parts per kind, silhouettes by median + Otsu."""
    from cell import sim
    from cell.scenario import scenario_from_dict
    from cell.sim import layout

    out = {}
    for kind in ("washer", "square_nut", "bolt"):
        scenario = scenario_from_dict(
            {"seed": 11, "lighting": "back",
             "parts": {"count": 2, "kinds": [kind], "materials": ["steel"]}}
        )
        world = sim.World.build(scenario, arm=False)
        world.place_next_part(-0.05, layout.CONVEYOR_Y, 0.3)
        world.place_next_part(0.05, layout.CONVEYOR_Y + 0.02, 1.2)
        world.step(100)
        grey = cv2.cvtColor(world.render("overhead", depth=False, seg=False).rgb,
                            cv2.COLOR_RGB2GRAY)
        world.close()
        grey = median(grey, ksize=3)
        comps = label_components(grey <= threshold_otsu(grey), min_area=50)
        h, w = grey.shape
        masks = []
        for i in range(comps.count):
            x, y, bw, bh = comps.bboxes[i]
            if x > 0 and y > 0 and x + bw < w and y + bh < h:  # not the dark frame
                masks.append(comps.mask(i + 1))
        out[kind] = [describe_shape(m) for m in masks]
    return out


def test_rendered_washer_nut_and_bolt(rendered_silhouettes):
    washers, nuts, bolts = (rendered_silhouettes[k] for k in ("washer", "square_nut", "bolt"))
    assert len(washers) == len(nuts) == len(bolts) == 2
    for d in washers:
        assert abs(d.circularity - 1) < 0.10 and d.holes == 1
    for d in nuts:
        assert d.circularity > max(w.circularity for w in washers) + 0.15
        assert d.holes == 1
    for d in bolts:
        assert d.aspect_ratio > 3


def test_shape_errors_name_the_argument():
    with pytest.raises(VisionError, match="mask"):
        describe_shape(np.zeros((5, 5), bool))
    with pytest.raises(VisionError, match="mask"):
        perimeter(np.zeros((5, 5), np.float32))


def _holed_square():
    mask = np.zeros((30, 30), bool)
    mask[5:25, 5:25] = True
    mask[10:13, 10:13] = False
    return mask


@pytest.mark.parametrize("value", [np.nan, -1, "2", 2.0, True, 2**31])
def test_hole_area_limits_are_checked(value):
    with pytest.raises(VisionError, match="argument 'min_area'"):
        count_holes(_holed_square(), min_area=value)
    with pytest.raises(VisionError, match="argument 'min_hole_area'"):
        describe_shape(_holed_square(), min_hole_area=value)


def test_a_single_pixel_has_no_compactness():
    a = np.zeros((5, 5), bool)
    a[2, 2] = True
    with pytest.raises(VisionError, match="mask.*single pixel"):
        compactness(a)
    with pytest.raises(VisionError, match="mask.*single pixel"):
        describe_shape(a)
    a[2, 3] = True  # two pixels: an outline of length 2
    assert compactness(a) == pytest.approx(0.5)


def test_every_shape_function_refuses_an_empty_mask():
    empty = np.zeros((5, 5), bool)
    for fn in (perimeter, aspect_ratio, circularity, compactness, hu_moments, orientation,
               count_holes, describe_shape):
        with pytest.raises(VisionError, match="mask.*empty"):
            fn(empty)


@pytest.mark.parametrize(("rows", "cols", "value"), [(2, 2, 16 / (4 * math.pi * 4)),
                                                      (1, 3, 16 / (4 * math.pi * 3)), (1, 1, 0.0)])
def test_a_tiny_region_is_less_than_circular_as_documented(rows, cols, value):
    mask = np.zeros((6, 6), bool)
    mask[1:1 + rows, 1:1 + cols] = True
    assert circularity(mask) == pytest.approx(value)


def test_largest_region_is_the_one_with_most_pixels():
    """A 2 x 200 wire (400 px) beside a 16 x 16 part with a hole (247 px): the wire is the
    largest region, though the outline through its pixel centres encloses almost nothing;
    a 1 x 100 line beats a 2 x 2 dot."""
    m = np.zeros((60, 260), bool)
    m[5:7, 20:220] = True
    m[30:46, 30:46] = True
    m[35:38, 35:38] = False
    assert perimeter(m) == perimeter(m[:20]) == 400.0
    assert count_holes(m) == 0 and count_holes(m[20:]) == 1
    line = np.zeros((40, 120), bool)
    line[5, 5:105] = True
    line[20:22, 20:22] = True
    assert perimeter(line) == 198.0


def test_rect_angle_of_a_vertical_bar_is_in_the_documented_range():
    """(-pi/2, pi/2], as orientation: a vertical bar is +pi/2 for both (was -pi/2)."""
    m = np.zeros((40, 40), bool)
    m[5:35, 18:22] = True
    d = describe_shape(m)
    assert d.rect_angle == pytest.approx(math.pi / 2) and d.orientation == pytest.approx(math.pi / 2)


def test_describe_shape_centroid_is_x_then_y():
    m = np.zeros((40, 80), bool)
    m[10:20, 30:60] = True  # rows 10..19, columns 30..59
    d = describe_shape(m)
    assert d.centroid == pytest.approx((44.5, 14.5))
