import numpy as np
import pytest

from cell.errors import VisionError
from cell.vision.labeling import label_components
from cell.vision.morphology import closing, dilate, erode, opening, separate_touching


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
