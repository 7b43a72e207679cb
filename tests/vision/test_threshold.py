import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from skimage import data
from skimage.filters import apply_hysteresis_threshold, threshold_isodata
from skimage.filters import threshold_otsu as sk_otsu

from cell.errors import VisionError
from cell.vision.threshold import (
    threshold_adaptive,
    threshold_fixed,
    threshold_hysteresis,
    threshold_iterative,
    threshold_otsu,
)


def _bimodal(seed, lo=70, hi=170, sigma=15):
    rng = np.random.default_rng(seed)
    img = rng.normal(lo, sigma, (120, 160))
    img[40:90, 50:120] = rng.normal(hi, sigma, (50, 70))
    return np.clip(img, 0, 255).astype(np.uint8)


def test_fixed_threshold_syllabus_example():
    img = np.array([[100, 150, 151, 255]], dtype=np.uint8)
    assert threshold_fixed(img, value=150).tolist() == [[False, False, True, True]]
    assert threshold_fixed(img, value=150, polarity="dark").tolist() == [[True, True, False, False]]


@pytest.mark.parametrize("seed", range(5))
def test_otsu_agrees_with_scikit_image(seed):
    img = _bimodal(seed, lo=60 + 5 * seed, hi=160 + 10 * seed)
    assert abs(threshold_otsu(img) - sk_otsu(img)) <= 1


@pytest.mark.parametrize("level", [0, 90, 255])
def test_otsu_of_one_grey_level_makes_no_bright_class(level):
    """One level has no two classes: the threshold is the level (scikit-image's answer),
    not OpenCV's 0, under which an evenly lit empty table was all object."""
    img = np.full((48, 64), level, np.uint8)
    assert threshold_otsu(img) == sk_otsu(img) == level
    assert not (img > threshold_otsu(img)).any()


def _is_isodata_fixed_point(img, t):
    """scikit-image's rule: t <= (mean of pixels <= t + mean of pixels > t) / 2 < t + 1."""
    low, high = img[img <= t], img[img > t]
    return 0.0 <= 0.5 * (low.mean() + high.mean()) - t < 1.0


@pytest.mark.parametrize("seed", range(5))
def test_ridler_calvard_agrees_with_isodata(seed):
    img = _bimodal(seed, lo=50 + 5 * seed, hi=180, sigma=10 + seed)
    t = threshold_iterative(img)
    assert t == threshold_isodata(img)
    assert _is_isodata_fixed_point(img, t)


@pytest.mark.parametrize("name", ["moon", "text", "camera", "coins"])
def test_iterative_equals_scikit_image_isodata_on_its_sample_images(name):
    """Several levels can satisfy the rule (moon: 86-88, 122-124, 139-140); both pick
    the lowest. Equal to the grey level, not within a tolerance."""
    img = getattr(data, name)()
    t = threshold_iterative(img)
    assert t == threshold_isodata(img)
    assert _is_isodata_fixed_point(img, t)
    assert t == threshold_isodata(img, return_all=True).min()


@settings(max_examples=200, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 30), st.integers(1, 30))),
       st.sampled_from([0, 1, 64]))
def test_iterative_equals_scikit_image_isodata_on_random_images(img, shift):
    img = img >> np.uint8(shift % 8)  # also narrow ranges: 0..255, 0..127, 0..3
    assert threshold_iterative(img) == threshold_isodata(img)


def test_iterative_on_a_single_grey_level_returns_that_level():
    img = np.full((5, 7), 42, np.uint8)
    assert threshold_iterative(img) == threshold_isodata(img) == 42


def _gradient_scene():
    """Parts 45 grey levels brighter than a belt lit by a left-to-right ramp 20..210."""
    h, w = 120, 320
    belt = np.tile(np.linspace(20, 210, w), (h, 1))
    truth = np.zeros((h, w), bool)
    for x in (20, 110, 200, 280):
        truth[40:75, x : x + 30] = True
    img = belt + 45 * truth + np.random.default_rng(5).normal(0, 3, (h, w))
    return np.clip(img, 0, 255).astype(np.uint8), truth


def _iou(a, b):
    return (a & b).sum() / (a | b).sum()


def test_adaptive_separates_parts_where_every_global_threshold_fails():
    img, truth = _gradient_scene()
    global_ious = [_iou(img > t, truth) for t in range(256)]
    assert max(global_ious) < 0.6  # no global level works
    for method in ("mean", "gaussian"):  # Gaussian weights need a wider block
        mask = threshold_adaptive(img, block_size=101, offset=12, method=method)
        assert _iou(mask, truth) > 0.9, method


def test_adaptive_dark_polarity_finds_silhouettes():
    img, truth = _gradient_scene()
    mask = threshold_adaptive(255 - img, block_size=61, offset=15, polarity="dark")
    assert _iou(mask, truth) > 0.9


def _rounded_local_mean(img, block_size, method):
    """The documented local level: the block mean (box or Gaussian weights with
    OpenCV's sigma from the size, replicated border) rounded to a grey level; and where
    that rounding is clear: the mean more than 1e-3 grey levels from a tie (x.5), or
    exactly on one (block 3's Gaussian weights 1/4, 1/2, 1/4 make exact sixteenths). A
    float mean that close to a tie may round either way on another CPU (its last bits
    depend on the vector width and fused multiply-add): the rule is not checked there."""
    if method == "mean":
        m = cv2.boxFilter(img.astype(np.float64), -1, (block_size, block_size),
                          borderType=cv2.BORDER_REPLICATE)
    else:
        m = cv2.GaussianBlur(img.astype(np.float32), (block_size, block_size), 0,
                             borderType=cv2.BORDER_REPLICATE)
    to_tie = np.abs(m - np.floor(m) - 0.5)
    clear = (to_tie > 1e-3) | (to_tie == 0)
    return np.rint(m), clear


@pytest.mark.parametrize("method", ["mean", "gaussian"])
@pytest.mark.parametrize("block_size", [3, 11, 31])
@pytest.mark.parametrize("offset", [0, 7, 7.5, -3.25, 12.9])
def test_adaptive_follows_its_documented_rule_and_opencv(method, block_size, offset):
    img = np.random.default_rng(block_size).integers(0, 256, (97, 131), dtype=np.uint8)
    img = cv2.GaussianBlur(img, (0, 0), 2.0)  # some local structure, many near-ties
    m, clear = _rounded_local_mean(img, block_size, method)
    assert clear.mean() > 0.99
    bright = threshold_adaptive(img, block_size=block_size, offset=offset, method=method)
    dark = threshold_adaptive(img, block_size=block_size, offset=offset, method=method,
                              polarity="dark")
    np.testing.assert_array_equal(bright[clear], (img > m + offset)[clear])
    np.testing.assert_array_equal(dark[clear], (img <= m - offset)[clear])
    cv_method = {"mean": cv2.ADAPTIVE_THRESH_MEAN_C, "gaussian": cv2.ADAPTIVE_THRESH_GAUSSIAN_C}
    cv = cv2.adaptiveThreshold(img, 255, cv_method[method], cv2.THRESH_BINARY, block_size, -offset)
    np.testing.assert_array_equal(bright, cv > 0)
    if float(offset).is_integer():  # OpenCV's THRESH_BINARY_INV floors a fractional C
        cv = cv2.adaptiveThreshold(img, 255, cv_method[method], cv2.THRESH_BINARY_INV,
                                   block_size, offset)
        np.testing.assert_array_equal(dark, cv > 0)


def test_hysteresis_keeps_a_faint_rim_and_drops_faint_noise():
    """A part clear in its middle (200) with a faint rim (60) is kept whole; a faint speck
    (60) alone, and the belt (20), are not; a rim touching only at a corner joins under
    8-connectivity, not 4."""
    img = np.full((20, 20), 20, np.uint8)
    img[4:10, 4:10] = 60
    img[6:8, 6:8] = 200
    img[15:17, 15:17] = 60  # a speck
    img[10, 10] = 60  # corner-touching the rim
    got = threshold_hysteresis(img, low=40, high=100)
    want = np.zeros_like(got)
    want[4:10, 4:10] = True
    want[10, 10] = True
    assert (got == want).all()
    assert not threshold_hysteresis(img, low=40, high=100, connectivity=4)[10, 10]
    assert (threshold_hysteresis(img, low=100, high=100) == (img > 100)).all()


@settings(max_examples=200, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 30), st.integers(1, 30))),
       st.integers(0, 255), st.integers(0, 255))
def test_hysteresis_with_4_connectivity_equals_scikit_image(img, a, b):
    low, high = min(a, b), max(a, b)
    got = threshold_hysteresis(img, low=low, high=high, connectivity=4)
    assert (got == apply_hysteresis_threshold(img, low, high)).all()


def test_threshold_errors_name_the_argument():
    with pytest.raises(VisionError, match="image"):
        threshold_otsu(np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(VisionError, match="block_size"):
        threshold_adaptive(np.zeros((9, 9), np.uint8), block_size=4)
    with pytest.raises(VisionError, match="method.*valid"):
        threshold_adaptive(np.zeros((9, 9), np.uint8), method="median")
    with pytest.raises(VisionError, match="low"):
        threshold_hysteresis(np.zeros((9, 9), np.uint8), low=50, high=40)
    with pytest.raises(VisionError, match="connectivity.*valid"):
        threshold_hysteresis(np.zeros((9, 9), np.uint8), low=10, high=40, connectivity=6)


_G = np.tile(np.arange(0, 256, 4, dtype=np.uint8), (16, 1))


@pytest.mark.parametrize(
    ("call", "name"),
    [(lambda: threshold_adaptive(_G, offset=np.nan), "offset"),
     (lambda: threshold_adaptive(_G, offset=np.inf), "offset"),
     (lambda: threshold_adaptive(_G, offset=1e18), "offset"),
     (lambda: threshold_adaptive(_G, offset=-256), "offset"),
     (lambda: threshold_adaptive(_G, offset="3"), "offset"),
     (lambda: threshold_adaptive(_G, offset=True), "offset"),
     (lambda: threshold_adaptive(_G, block_size=10**18 + 1), "block_size"),
     (lambda: threshold_adaptive(_G, block_size=5.0), "block_size"),
     (lambda: threshold_fixed(_G, value="100"), "value"),
     (lambda: threshold_fixed(_G, value=None), "value"),
     (lambda: threshold_fixed(_G, value=np.array([10, 20])), "value"),
     (lambda: threshold_fixed(_G, value=np.nan), "value"),
     (lambda: threshold_hysteresis(_G, low=10, high="100"), "high"),
     (lambda: threshold_hysteresis(_G, low=None, high=100), "low"),
     (lambda: threshold_hysteresis(_G, low=10, high=np.array([10, 20])), "high"),
     (lambda: threshold_hysteresis(_G, low=10, high=100, connectivity=4.0), "connectivity"),
     (lambda: threshold_hysteresis(_G, low=10, high=100, connectivity=True), "connectivity")],
)
def test_threshold_numbers_are_checked(call, name):
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        call()


def test_adaptive_offset_limits_are_accepted():
    assert not threshold_adaptive(_G, block_size=3, offset=255).any()
    assert threshold_adaptive(_G, block_size=3, offset=-255).all()


@pytest.mark.parametrize("block_size", [3, 5, 7, 9, 31])
def test_adaptive_gaussian_mean_is_the_documented_kernel(block_size):
    """The Gaussian mean is ``cv2.getGaussianKernel(block_size, 0)``: OpenCV's fixed tables
    for 3, 5 and 7 (the sigma rule the docstring gave alone differed at 408-665 pixels of
    76,800), its sigma rule from 9 on. Decisions compared; a rounding tie may differ."""
    img = cv2.GaussianBlur(np.random.default_rng(0).integers(0, 256, (240, 320), dtype=np.uint8),
                           (0, 0), 1.5)
    k = cv2.getGaussianKernel(block_size, 0)
    mean = cv2.sepFilter2D(img.astype(np.float64), -1, k, k, borderType=cv2.BORDER_REPLICATE)
    documented = img > np.rint(mean) + 2
    got = threshold_adaptive(img, block_size=block_size, offset=2, method="gaussian")
    assert np.count_nonzero(documented != got) <= 5
