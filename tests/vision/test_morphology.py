import numpy as np
import pytest

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
    sim = pytest.importorskip("cell.sim")
    import cv2

    from cell.scenario import scenario_from_dict
    from cell.sim import layout
    from cell.vision.threshold import threshold_otsu

    scenario = scenario_from_dict(
        {"seed": 3, "lighting": "back",
         "parts": {"count": 2, "kinds": ["washer"], "materials": ["steel"]}}
    )
    world = sim.World.build(scenario, arm=False)
    world.place_next_part(-0.01, layout.CONVEYOR_Y, 0.0)
    world.place_next_part(0.0103, layout.CONVEYOR_Y + 0.003, 0.0)
    world.step(150)
    frame = world.render("overhead", depth=False, seg=True)
    world.close()
    grey = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2GRAY)
    mask = grey <= threshold_otsu(grey)
    mask &= np.abs(np.arange(mask.shape[0])[:, None] - mask.shape[0] / 2) < 110  # belt only
    assert label_components(mask, min_area=50).count == 1  # the washers touch
    labels = separate_touching(mask, method=method)
    assert labels.max() == 2
    for lab in (1, 2):  # each region is one washer (segmentation truth, scoring only)
        ids = frame.seg[labels == lab]
        assert np.bincount(ids).max() / len(ids) > 0.98
