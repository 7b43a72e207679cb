import numpy as np
import pytest

from cell.errors import VisionError
from cell.vision.smoothing import gaussian_iterated, median


def test_iterated_gaussian_lowers_noise_monotonically():
    rng = np.random.default_rng(2)
    clean = np.full((120, 160), 128.0)
    noisy = np.clip(clean + rng.normal(0, 20, clean.shape), 0, 255).astype(np.uint8)
    stds = [gaussian_iterated(noisy, iterations=n)[4:-4, 4:-4].std() for n in range(0, 7)]
    assert all(b < a for a, b in zip(stds, stds[1:], strict=False)), stds
    assert stds[-1] < stds[0] / 4


def test_iterated_gaussian_equals_wider_gaussian():
    # n passes of the binomial 3x3 kernel == one Gaussian of variance n/2 (interior).
    rng = np.random.default_rng(3)
    img = rng.random((64, 64)).astype(np.float32)
    out = gaussian_iterated(img, iterations=1)
    k = np.array([0.25, 0.5, 0.25])
    ref = sum(k[i] * k[j] * np.roll(np.roll(img, 1 - i, 0), 1 - j, 1)
              for i in range(3) for j in range(3))
    np.testing.assert_allclose(out[1:-1, 1:-1], ref[1:-1, 1:-1], atol=1e-5)


def test_median_removes_salt_and_pepper_that_gaussian_smears():
    rng = np.random.default_rng(4)
    clean = np.full((120, 160), 100, np.uint8)
    clean[30:90, 40:120] = 180  # a part with sharp edges
    noisy = clean.copy()
    r = rng.random(clean.shape)
    noisy[r < 0.05] = 0
    noisy[r > 0.95] = 255
    med = median(noisy, ksize=3)
    gau = gaussian_iterated(noisy, iterations=2)

    def bad_fraction(img):
        return float(np.mean(np.abs(img.astype(int) - clean) > 20))

    before, after_med, after_gau = bad_fraction(noisy), bad_fraction(med), bad_fraction(gau)
    assert before > 0.09
    assert after_med < 0.01  # median removes almost every outlier
    assert after_gau > 0.05  # Gaussian spreads each outlier into its neighbours
    assert after_gau > 10 * after_med


def test_smoothing_rejects_bad_arguments():
    with pytest.raises(VisionError, match="ksize"):
        median(np.zeros((5, 5), np.uint8), ksize=4)
    with pytest.raises(VisionError, match="iterations"):
        gaussian_iterated(np.zeros((5, 5), np.uint8), iterations=-1)
    with pytest.raises(VisionError, match="image"):
        median(np.zeros((5, 5), np.float32))


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_gaussian_refuses_a_nan_pixel(value):
    img = np.ones((20, 20), np.float32)
    img[5, 5] = value
    with pytest.raises(VisionError, match="argument 'image'.*finite"):
        gaussian_iterated(img)


@pytest.mark.parametrize(
    ("kw", "name"),
    [({"iterations": 10**12}, "iterations"), ({"iterations": True}, "iterations"),
     ({"iterations": 2.0}, "iterations"), ({"iterations": 1366}, "iterations"),
     ({"ksize": 31, "iterations": 133}, "iterations"),
     ({"sigma": np.nan}, "sigma"), ({"sigma": np.inf}, "sigma"), ({"sigma": 1e18}, "sigma"),
     ({"sigma": -2.0}, "sigma"), ({"sigma": "1"}, "sigma"), ({"sigma": True}, "sigma"),
     ({"ksize": True}, "ksize"), ({"ksize": 10**18 + 1}, "ksize"), ({"ksize": 3.0}, "ksize")],
)
def test_gaussian_checks_its_numbers(kw, name):
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        gaussian_iterated(np.zeros((20, 20), np.uint8), **kw)


def test_gaussian_bounds_accept_the_limits():
    img = np.zeros((8, 8), np.uint8)
    assert gaussian_iterated(img, iterations=1365).shape == (8, 8)  # 1365 x 3 <= 4096
    assert gaussian_iterated(img, ksize=4095, sigma=4095.0).shape == (8, 8)


@pytest.mark.parametrize("ksize", [257, 365, 1001, 2**31 + 1, 3.0, True])
def test_median_refuses_windows_opencv_cannot_count(ksize):
    # uint8 windows above 255 x 255 overflow OpenCV's 16-bit histogram counts (an
    # assertion, or a wrong median: 365 on a two-level image)
    img = np.full((64, 64), 40, np.uint8)
    img[40:] = 200
    with pytest.raises(VisionError, match="argument 'ksize'.*3 to 255"):
        median(img, ksize=ksize)
    assert median(img, ksize=255).shape == (64, 64)
