import math

import numpy as np
import pytest
from skimage.color import rgb2hsv, rgb2lab

from cell.errors import VisionError
from cell.vision.colour import colour_stats, convert_colour


def test_conversions_match_scikit_image():
    rng = np.random.default_rng(12)
    rgb = rng.integers(0, 256, (20, 30, 3), dtype=np.uint8)
    lab = convert_colour(rgb, to="lab")
    np.testing.assert_allclose(lab, rgb2lab(rgb), atol=0.5)
    hsv = convert_colour(rgb, to="hsv")
    ref = rgb2hsv(rgb)
    np.testing.assert_allclose(hsv[..., 1:], ref[..., 1:], atol=1e-3)
    dh = np.abs(hsv[..., 0] - 360 * ref[..., 0])
    assert np.all(np.minimum(dh, 360 - dh)[ref[..., 1] > 0.05] < 0.5)
    # the same colours in BGR order: OpenCV's other conversion code, so within 1e-4 (a
    # last-bit difference on another CPU passes, a channel swap is tens of units off)
    np.testing.assert_allclose(convert_colour(rgb[..., ::-1].copy(), to="lab", order="bgr"), lab,
                               rtol=0, atol=1e-4)


def test_stats_of_known_regions():
    img = np.zeros((20, 40, 3), np.uint8)
    img[:, :20] = (255, 0, 0)  # red
    img[:, 20:] = (128, 128, 128)  # grey
    left = np.zeros((20, 40), bool)
    left[:, :20] = True
    red = colour_stats(img, left)
    assert red.count == 400
    assert red.hue_mean == pytest.approx(0.0, abs=0.1) and red.hue_std < 0.1
    assert red.sat_mean == pytest.approx(1.0) and red.chroma_mean > 100
    grey = colour_stats(img, ~left)
    assert grey.sat_mean == 0 and np.isnan(grey.hue_mean)
    assert grey.lab_mean[0] == pytest.approx(53.6, abs=0.5)
    assert grey.chroma_mean < 1


def test_hue_mean_wraps_around_red():
    img = np.zeros((1, 2, 3), np.uint8)
    img[0, 0] = (255, 0, 20)  # hue ~355 deg
    img[0, 1] = (255, 20, 0)  # hue ~5 deg
    st = colour_stats(img, np.ones((1, 2), bool))
    assert min(st.hue_mean, 360 - st.hue_mean) < 1.0  # not 180


def test_highlight_fraction_counts_bright_colourless_pixels():
    img = np.full((10, 10, 3), (200, 150, 60), np.uint8)  # brass-like
    img[:2] = 250  # a specular streak
    st = colour_stats(img, np.ones((10, 10), bool))
    assert st.highlight_fraction == pytest.approx(0.2)


def test_colour_errors_name_the_argument():
    img = np.zeros((4, 4, 3), np.uint8)
    with pytest.raises(VisionError, match="mask.*match"):
        colour_stats(img, np.ones((3, 4), bool))
    with pytest.raises(VisionError, match="mask"):
        colour_stats(img, np.zeros((4, 4), bool))
    with pytest.raises(VisionError, match="image"):
        convert_colour(np.zeros((4, 4), np.uint8), to="hsv")
    with pytest.raises(VisionError, match="to.*valid"):
        convert_colour(img, to="yuv")


@pytest.mark.parametrize("name", ["highlight_v", "highlight_s"])
@pytest.mark.parametrize("value", [np.nan, 5.0, -1, "0.9", np.inf, True])
def test_colour_stats_refuses_bad_highlight_limits(name, value):
    img = np.full((4, 4, 3), 200, np.uint8)
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        colour_stats(img, np.ones((4, 4), bool), **{name: value})


def test_hue_std_is_the_circular_standard_deviation():
    """Half the pixels at hue -30 deg, half at +30 deg (full saturation): the mean
    resultant length is cos 30 deg, the circular std sqrt(-2 ln R) = 30.7 deg."""
    img = np.zeros((2, 10, 3), np.uint8)
    img[0] = (255, 0, 128)  # hue 330 deg
    img[1] = (255, 128, 0)  # hue 30 deg
    s = colour_stats(img, np.ones((2, 10), bool))
    r = math.cos(math.radians(30.1))  # 128/255 gives 30.1 deg, not 30
    expected = math.degrees(math.sqrt(-2.0 * math.log(r)))
    assert s.hue_mean == pytest.approx(0.0, abs=0.2) or s.hue_mean == pytest.approx(360.0, abs=0.2)
    assert s.hue_std == pytest.approx(expected, abs=0.3)
