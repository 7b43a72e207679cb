import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.errors import VisionError
from cell.vision.labeling import label_components
from cell.vision.morphology import (
    closing,
    dilate,
    erode,
    fill_holes,
    opening,
    separate_touching,
)


def test_syllabus_erosion_leaves_only_the_centre():
    img = np.zeros((5, 5), np.uint8)
    img[1:4, 1:4] = 1
    out = erode(img, size=3)
    expected = np.zeros((5, 5), np.uint8)
    expected[2, 2] = 1
    np.testing.assert_array_equal(out, expected)
    # and dilating the centre back gives the 3x3 square
    np.testing.assert_array_equal(dilate(out, size=3), img)


def test_opening_removes_specks_closing_fills_gaps():
    mask = np.zeros((40, 40), bool)
    mask[10:30, 10:30] = True
    specks = mask.copy()
    specks[2, 2] = specks[35, 5] = True
    np.testing.assert_array_equal(opening(specks, size=3), mask)
    holed = mask.copy()
    holed[20, 20] = holed[15, 16] = False
    np.testing.assert_array_equal(closing(holed, size=3), mask)
    assert closing(holed).dtype == bool


def _two_touching_discs():
    yy, xx = np.mgrid[0:80, 0:120]
    a = (xx - 40) ** 2 + (yy - 40) ** 2 <= 20**2
    b = (xx - 76) ** 2 + (yy - 42) ** 2 <= 18**2
    return a, b


@pytest.mark.parametrize("method", ["distance", "erosion"])
def test_touching_parts_are_separated(method):
    a, b = _two_touching_discs()
    mask = a | b
    assert label_components(mask).count == 1  # touching: one blob
    labels = separate_touching(mask, method=method)
    assert labels.max() == 2
    assert np.all((labels > 0) == mask)
    # each label sits on one disc: >= 95 % of its pixels are in the same true disc
    for lab in (1, 2):
        region = labels == lab
        overlap = max((region & a).sum(), (region & b).sum())
        assert overlap / region.sum() > 0.95


def test_separate_keeps_single_parts_whole():
    mask = np.zeros((60, 60), bool)
    mask[10:30, 10:50] = True
    labels = separate_touching(mask)
    assert labels.max() == 1 and np.all((labels == 1) == mask)
    assert separate_touching(np.zeros((8, 8), bool)).max() == 0


def test_morphology_errors_name_the_argument():
    with pytest.raises(VisionError, match="image"):
        erode(np.zeros((4, 4), np.float32))
    with pytest.raises(VisionError, match="shape.*valid"):
        dilate(np.zeros((4, 4), bool), shape="star")
    with pytest.raises(VisionError, match="method"):
        separate_touching(np.zeros((4, 4), bool), method="magic")


def test_fill_holes():
    ring = np.zeros((30, 30), bool)
    ring[5:25, 5:25] = True
    ring[10:15, 10:15] = False  # a hole
    ring[0:3, 12:18] = False  # nothing: already background at the border
    filled = fill_holes(ring)
    assert filled[10:15, 10:15].all() and filled.sum() == 400


@pytest.mark.parametrize("method", ["distance", "erosion"])
def test_touching_rendered_washers_are_separated(method):
    """Two steel washers placed touching, back-lit: one dark blob, two parts."""
    import cv2

    from cell import sim
    from cell.scenario import scenario_from_dict
    from cell.sim import layout
    from cell.vision.threshold import threshold_otsu

    scenario = scenario_from_dict(
        {"seed": 3, "lighting": "back",
         "parts": {"count": 2, "kinds": ["washer"], "materials": ["steel"]}}
    )
    world = sim.World.build(scenario, arm=False)
    world.place_next_part(-0.01, layout.CONVEYOR_Y, 0.0)
    world.place_next_part(0.0097, layout.CONVEYOR_Y + 0.003, 0.0)  # 20 mm apart: touching
    world.step(150)
    frame = world.render("overhead", depth=False, seg=True)
    world.close()
    a, b = (p.id for p in world.parts)
    grown = cv2.dilate((frame.seg == a).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    assert (grown & (frame.seg == b)).any(), "the scene must really have touching washers"
    grey = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2GRAY)
    mask = grey <= threshold_otsu(grey)
    mask &= np.abs(np.arange(mask.shape[0])[:, None] - mask.shape[0] / 2) < 110  # belt only
    assert label_components(mask, min_area=50).count == 1  # the washers touch
    labels = separate_touching(mask, method=method)
    assert labels.max() == 2
    for lab in (1, 2):  # each region is one washer (segmentation truth, scoring only)
        ids = frame.seg[labels == lab]  # (the cut may stray a pixel or two from the contact)
        assert np.bincount(ids).max() / len(ids) > 0.95


_M = np.zeros((64, 64), bool)
_M[10:40, 20:50] = True


@pytest.mark.parametrize("op", [erode, dilate, opening, closing])
@pytest.mark.parametrize(
    ("kw", "name"),
    [({"size": -3}, "size"), ({"size": 3.0}, "size"), ({"size": "3"}, "size"),
     ({"size": np.nan}, "size"), ({"size": True}, "size"), ({"size": 2**31 + 1}, "size"),
     ({"size": 259}, "size"), ({"size": 10001}, "size"), ({"size": 100001}, "size"),
     ({"iterations": -2}, "iterations"), ({"iterations": np.nan}, "iterations"),
     ({"iterations": 2.0}, "iterations"), ({"iterations": 10**6}, "iterations"),
     ({"size": 3, "iterations": 129}, "iterations"),  # reach 129 > 128 px
     ({"size": 257, "iterations": 2}, "iterations")],
)
def test_size_and_iterations_are_bounded(op, kw, name):
    # a 10001 closing hung; 10**6 iterations asked OpenCV for a 400 GB element
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        op(_M, **kw)


@pytest.mark.parametrize("op", [erode, dilate, opening, closing])
def test_the_reach_limits_are_accepted(op):
    assert op(_M, size=257, shape="disk").shape == _M.shape
    assert op(_M, size=3, iterations=128).shape == _M.shape
    assert op(_M, iterations=0).shape == _M.shape


@pytest.mark.parametrize("size", [True, 4097, 2**31 + 1, 3.0])
def test_structuring_element_size_is_checked(size):
    from cell.vision.morphology import structuring_element

    with pytest.raises(VisionError, match="argument 'size'"):
        structuring_element(size)


@pytest.mark.parametrize("method", ["distance", "erosion"])
def test_separate_touching_a_mask_without_background(method):
    # the distance transform of an all-foreground mask is 3.4e38 everywhere; outside
    # the image now counts as background
    labels = separate_touching(np.ones((50, 50), bool), method=method)
    assert labels.max() == 1 and (labels == 1).all()
    holed = np.ones((40, 40), bool)
    holed[15:25, 15:25] = False  # filled for the markers: no background left either
    labels = separate_touching(holed, method=method)
    assert labels.max() == 1 and ((labels == 1) == holed).all()


@pytest.mark.parametrize(
    ("kw", "name"),
    [({"ratio": "0.5"}, "ratio"), ({"ratio": np.nan}, "ratio"), ({"ratio": 0.0}, "ratio"),
     ({"ratio": 1.0}, "ratio"), ({"max_iterations": -3}, "max_iterations"),
     ({"max_iterations": 2.5}, "max_iterations"), ({"max_iterations": "3"}, "max_iterations"),
     ({"max_iterations": 10**6}, "max_iterations"), ({"size": 4}, "size"),
     ({"size": 1}, "size"), ({"size": 259}, "size"), ({"method": "erosion", "size": 4}, "size")],
)
def test_separate_touching_checks_its_numbers(kw, name):
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        separate_touching(_M, **kw)


def test_separate_touching_with_an_element_wider_than_the_part():
    a, b = _two_touching_discs()
    labels = separate_touching(a | b, method="erosion", size=101)
    assert labels.max() == 1 and ((labels > 0) == (a | b)).all()


def _flood_whole_image(labels, fg, dist, step=0.5):
    """The watershed by immersion written plainly: every level scans the whole image."""
    import cv2

    out = labels.astype(np.int32).copy()
    for level in [*np.arange(float(dist.max()), 0.0, -step), 0.0]:
        allowed = fg & (dist >= level) & (out == 0)
        while allowed.any():
            grown = cv2.dilate(out.astype(np.float32), np.ones((3, 3), np.uint8)).astype(np.int32)
            new = allowed & (grown > 0)
            if not new.any():
                break
            out[new] = grown[new]
            allowed &= ~new
    return out


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.3, 0.6, 0.9]))
def test_flood_equals_the_whole_image_watershed(seed, ratio):
    import cv2

    from cell.vision import morphology

    rng = np.random.default_rng(seed)
    h, w = rng.integers(1, 90, 2)
    img = np.zeros((h, w), np.uint8)
    for _ in range(rng.integers(1, 7)):
        cv2.circle(img, (int(rng.integers(0, w)), int(rng.integers(0, h))),
                   int(rng.integers(1, 25)), 1, -1)
    solid = fill_holes(img > 0)
    cores, dist = morphology._markers_by_distance(solid, ratio)
    labels = label_components(cores).labels
    np.testing.assert_array_equal(morphology._flood(labels, solid, dist, step=0.5),
                                  _flood_whole_image(labels, solid, dist))


def test_separate_touching_a_large_mask():
    # (the whole-image flood took minutes here, the waiting-pixels flood about 1 s; the
    # speed itself is a benchmark's business, not a test's)
    import cv2

    a = np.zeros((2000, 2000), np.uint8)
    cv2.circle(a, (650, 1000), 500, 1, -1)
    cv2.circle(a, (1550, 1000), 420, 1, -1)
    labels = separate_touching(a > 0)
    assert labels.max() == 2 and labels[1000, 650] != labels[1000, 1550]


@pytest.mark.parametrize("shape", ["square", "cross", "disk"])
@pytest.mark.parametrize("size", [3, 5])
def test_closing_twice_is_closing_once(shape, size):
    """Closing is idempotent, along the border too (replicate padding changed 2-8 border
    pixels on a second closing); a region at the border is not eaten."""
    mask = np.random.default_rng(5).random((40, 50)) > 0.6
    once = closing(mask, size=size, shape=shape)
    np.testing.assert_array_equal(closing(once, size=size, shape=shape), once)
    assert (once >= mask).all()  # closing only adds
    edge = np.zeros((20, 20), bool)
    edge[:, :3] = True
    np.testing.assert_array_equal(closing(edge, size=size, shape=shape), edge)


def test_fill_holes_fills_inside_a_one_pixel_diagonal_ring():
    """A diamond drawn one pixel thick closes only through corners: the background inside
    cannot reach the border through edges (4-connected), so it is a hole and is filled."""
    mask = np.zeros((11, 11), bool)
    for k in range(5):
        for y, x in ((k, 5 + k), (5 + k, 10 - k), (10 - k, 5 - k), (5 - k, k)):
            mask[y, x] = True
    filled = fill_holes(mask)
    assert filled[5, 5] and filled.sum() == 61  # the ring's 20 pixels and the 41 inside them
