import numpy as np
import pytest
from skimage.filters import threshold_isodata
from skimage.filters import threshold_otsu as sk_otsu

from cell.errors import VisionError
from cell.vision.threshold import (
    threshold_adaptive,
    threshold_fixed,
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


@pytest.mark.parametrize("seed", range(5))
def test_ridler_calvard_agrees_with_isodata(seed):
    img = _bimodal(seed, lo=50 + 5 * seed, hi=180, sigma=10 + seed)
    t = threshold_iterative(img)
    assert abs(t - threshold_isodata(img)) <= 1
    # and it is a fixed point of the rule: midpoint of the two class means
    low, high = img[img <= t], img[img > t]
    assert abs(t - 0.5 * (low.mean() + high.mean())) < 1.0


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


def test_threshold_errors_name_the_argument():
    with pytest.raises(VisionError, match="image"):
        threshold_otsu(np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(VisionError, match="block_size"):
        threshold_adaptive(np.zeros((9, 9), np.uint8), block_size=4)
    with pytest.raises(VisionError, match="method.*valid"):
        threshold_adaptive(np.zeros((9, 9), np.uint8), method="median")
