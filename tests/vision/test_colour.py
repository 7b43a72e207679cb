import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage.color import rgb2hsv, rgb2lab

from cell.errors import VisionError
from cell.vision.colour import colour_stats, convert_colour, unclipped_mean


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


# unclipped_mean: a channel's mean before the sensor clipped its noise


def _clipped_mean(mu: float, sigma: float) -> float:
    """E[clip(mu + sigma Z, 0, 255)] from scipy.stats: the share inside times the truncated
    normal's mean, plus 255 times the share above (none below counts: it reads 0). The
    reference the closed form in unclipped_mean is checked against."""
    from scipy import stats

    a, b = (0.0 - mu) / sigma, (255.0 - mu) / sigma
    inside = stats.norm.cdf(b) - stats.norm.cdf(a)
    return inside * stats.truncnorm.mean(a, b, loc=mu, scale=sigma) + 255.0 * stats.norm.sf(b)


@settings(max_examples=60, deadline=None)
@given(mu=st.floats(0.0, 255.0), sigma=st.floats(0.5, 100.0))
def test_unclipped_mean_inverts_the_clipped_mean(mu, sigma):
    assert unclipped_mean(_clipped_mean(mu, sigma), sigma=sigma) == pytest.approx(mu, abs=0.01)


def test_unclipped_mean_takes_a_noisy_sensors_drift_back():
    """Yellow plastic's blue of 19 and a blue belt's red of 59 under noise of sigma 75,
    drawn and clipped as the sensor does: their means read 40 and 68; taken back, 19 and 59."""
    rng = np.random.default_rng(3)
    noisy = np.clip(np.rint(np.array([19.0, 59.0]) + 75 * rng.standard_normal((400_000, 2))), 0, 255)
    drifted = noisy.mean(axis=0)
    assert drifted == pytest.approx([40.4, 68.1], abs=0.5)
    assert unclipped_mean(drifted, sigma=75) == pytest.approx([19, 59], abs=0.5)


def test_unclipped_mean_ends_and_shapes():
    means = np.array([[0.0, 128.0, 255.0], [3.0, 100.0, 252.0]])
    assert unclipped_mean(means, sigma=0).tolist() == means.tolist()  # no noise, no drift
    got = unclipped_mean(means, sigma=5)
    assert got.shape == (2, 3) and got[0].tolist() == [0.0, pytest.approx(128.0, abs=1e-9), 255.0]
    assert got[1, 0] < 3.0 and got[1, 2] > 252.0  # a dark mean was lifted, a bright one lowered
    assert unclipped_mean(127.5, sigma=40) == pytest.approx(127.5, abs=0.01)  # symmetric: no drift
    assert unclipped_mean(np.zeros((0, 3)), sigma=4).shape == (0, 3)


@pytest.mark.parametrize("mean, sigma, culprit", [
    (np.array([np.nan]), 4.0, "'mean'"), (256.0, 4.0, "'mean'"), (-1.0, 4.0, "'mean'"),
    ("x", 4.0, "'mean'"), (10.0, -1.0, "'sigma'"), (10.0, float("inf"), "'sigma'"),
    (10.0, 256.0, "'sigma'"),
])
def test_unclipped_mean_refuses_bad_values(mean, sigma, culprit):
    with pytest.raises(VisionError, match=culprit):
        unclipped_mean(mean, sigma=sigma)
