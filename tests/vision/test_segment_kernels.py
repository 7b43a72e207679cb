"""The compiled segmentation steps against the OpenCV calls they replace, bit for bit."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cell.vision._median_kernel import median15
from cell.vision._segment_kernel import difference, open2
from cell.vision._smooth_kernel import box_difference, smoothing_taps


@pytest.mark.parametrize("shape", [(60, 80), (31, 47), (16, 16), (9, 23)])
def test_belt_median_is_opencv_median_of_the_mirrored_image(shape):
    rng = np.random.default_rng(sum(shape))
    small = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    small[: shape[0] // 2] //= 4  # a step, as a belt edge, and many ties
    got = np.empty_like(small)
    median15(small, got)
    padded = cv2.copyMakeBorder(small, 7, 7, 7, 7, cv2.BORDER_REFLECT_101)
    expect = cv2.medianBlur(padded, 15)[7:-7, 7:-7]
    np.testing.assert_array_equal(got, expect)


def _half_difference(img: np.ndarray, bg_small: np.ndarray, blurred: np.ndarray) -> np.ndarray:
    """The largest channel difference at every other pixel, as composed from OpenCV."""
    h, w = img.shape[0] // 2, img.shape[1] // 2
    bg = cv2.resize(bg_small, (w, h), interpolation=cv2.INTER_LINEAR)
    half = cv2.resize(blurred, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_NEAREST)
    return cv2.absdiff(half, bg).max(axis=2)


def _frame(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    img = np.full((96, 128, 3), (60, 80, 110), np.uint8)
    cv2.circle(img, (50, 40), 18, (200, 60, 50), -1)
    img = cv2.add(img, rng.integers(0, 25, img.shape, dtype=np.uint8))
    return img, np.full((12, 16, 3), (62, 90, 118), np.uint8)


def test_difference_is_opencv_absdiff_largest_channel():
    img, bg_small = _frame(1)
    h, w = 48, 64
    bg = cv2.resize(bg_small, (w, h), interpolation=cv2.INTER_LINEAR).reshape(h, 3 * w)
    got = np.empty((h, w), np.uint8)
    difference(img.reshape(96, 3 * 128), bg, True, got)  # the rows the noise estimate reads
    difference(img.reshape(96, 3 * 128), bg, False, got)  # and the others
    np.testing.assert_array_equal(got, _half_difference(img, bg_small, img))


@pytest.mark.parametrize("k", [3, 5])
def test_box_smoothed_difference_is_opencv_blur(k):
    img, bg_small = _frame(2)
    h, w = 48, 64
    bg = cv2.resize(bg_small, (w, h), interpolation=cv2.INTER_LINEAR).reshape(h, 3 * w)
    got = np.empty((h, w), np.uint8)
    box_difference(img.reshape(96, 3 * 128), bg, k, smoothing_taps(k, 0.0), got)
    np.testing.assert_array_equal(got, _half_difference(img, bg_small, cv2.blur(img, (k, k))))


def test_gaussian_taps_are_opencvs_kernel_in_256ths():
    for k, sigma in ((5, 1.0), (5, 1.5), (3, 0.8), (7, 2.0)):
        taps = smoothing_taps(k, sigma).astype(int)
        assert taps.sum() == 256 and list(taps) == list(taps[::-1])
        ref = cv2.getGaussianKernel(k, sigma).ravel() * 256
        assert np.abs(taps - ref).max() <= 1.5  # rounded; the centre tap takes the remainder
    assert smoothing_taps(5, 0.0).size == 0


@pytest.mark.parametrize(("k", "sigma"), [(1, 1.0), (3, 0.8), (5, 1.0), (7, 2.0), (9, 1.5)])
@pytest.mark.parametrize(("hh", "ww"), [(48, 64), (37, 63)])
def test_gaussian_smoothed_difference_is_the_integer_separable_filter(k, sigma, hh, ww):
    """Vertical then horizontal sums of the 1/256 taps (mirrored borders, as
    ``cv2.copyMakeBorder`` BORDER_REFLECT_101), rounded: (sum + 32768) >> 16, at every
    other pixel (odd sizes too: the last column and row are kept)."""
    rng = np.random.default_rng(k)
    img = rng.integers(0, 256, (hh, ww, 3), dtype=np.uint8)
    h, w = round(hh / 2), round(ww / 2)
    bg = rng.integers(0, 256, (h, 3 * w), dtype=np.uint8)
    taps = smoothing_taps(k, sigma)
    got = np.empty((h, w), np.uint8)
    box_difference(img.reshape(hh, 3 * ww), bg, k, taps, got)
    r, t = k // 2, taps.astype(np.int64)
    p = cv2.copyMakeBorder(img, r, r, r, r, cv2.BORDER_REFLECT_101).astype(np.int64)
    vert = sum(t[j] * p[j : j + hh] for j in range(k))
    smooth = (sum(t[j] * vert[:, j : j + ww] for j in range(k)) + 32768) >> 16
    expect = np.abs(smooth[::2, ::2][:h, :w] - bg.reshape(h, w, 3)).max(axis=2)
    np.testing.assert_array_equal(got, expect)


@pytest.mark.parametrize("k", [1, 3, 5, 7, 9])
@pytest.mark.parametrize("n_px", [40, 41])
def test_even_horizontal_is_the_horizontal_pass_at_even_pixels(k, n_px):
    """The horizontal pass at the even pixels alone, from the row split into even and
    odd pixels, is the full pass (:func:`horizontal`) kept at every other pixel."""
    from cell.vision._smooth_kernel import _split_pixels, even_horizontal, horizontal

    rng = np.random.default_rng(n_px + k)
    taps = smoothing_taps(k, 1.5).astype(np.int32)
    col = rng.integers(0, 65281, 3 * (n_px + k - 1), dtype=np.uint16)  # (at most 255 x 256)
    full = np.empty(3 * n_px, np.uint8)
    horizontal(col, taps, np.empty(3 * n_px, np.int32), full)
    pairs = (n_px + k) // 2
    padded = np.zeros(6 * pairs, np.uint16)
    padded[: col.size] = col
    ev, od = np.empty(3 * pairs, np.uint16), np.empty(3 * pairs, np.uint16)
    _split_pixels(padded, ev, od)
    w = (n_px + 1) // 2
    got = np.empty(3 * w, np.uint8)
    even_horizontal(ev, od, taps, np.empty(3 * w, np.int32), got)
    np.testing.assert_array_equal(got.reshape(w, 3), full.reshape(n_px, 3)[::2])


@pytest.mark.parametrize(("k", "sigma"), [(1, 1.0), (3, 0.8), (5, 1.0), (7, 2.0)])
def test_gaussian_window_is_the_integer_separable_filter(k, sigma):
    """A window smoothed at once, across its rows' ends (``gaussian_window``), is the
    same integer filter: (sum + 32768) >> 16 of the 1/256 taps."""
    from cell.vision._smooth_kernel import gaussian_window

    rng = np.random.default_rng(k)
    h, w, pad = 23, 31, max(k // 2, 1)
    o = pad - k // 2
    win = rng.integers(0, 256, (h + 2 * pad, w + 2 * pad, 3), dtype=np.uint8)
    wide, size = 3 * (w + 2 * pad), win.size
    taps = smoothing_taps(k, sigma)
    out = np.zeros(size, np.uint8)
    gaussian_window(win.ravel(), wide, h, w, o, taps.astype(np.int32),
                    np.empty(size, np.uint16), np.empty(size, np.int32), out)
    t = taps.astype(np.int64)
    p = win[o : o + h + k - 1, o : o + w + k - 1].astype(np.int64)
    vert = sum(t[j] * p[j : j + h] for j in range(k))
    expect = (sum(t[j] * vert[:, j : j + w] for j in range(k)) + 32768) >> 16
    got = out[: h * wide].reshape(h, wide)[:, : 3 * w].reshape(h, w, 3)
    np.testing.assert_array_equal(got, expect)


def test_gaussian_smoothing_reduces_noise_more_gently_than_the_box_at_an_edge():
    """On a noisy step edge the Gaussian leaves less noise than none and a steeper edge
    than the box filter of the same aperture."""
    rng = np.random.default_rng(5)
    img = np.zeros((96, 128, 3), np.uint8)
    img[:, 64:] = 120
    img = cv2.add(img, rng.integers(0, 30, img.shape, dtype=np.uint8))
    bg = np.zeros((48, 3 * 64), np.uint8)
    flat = img.reshape(96, 3 * 128)
    out = {}
    for name, taps in (("box", smoothing_taps(5, 0.0)), ("gauss", smoothing_taps(5, 1.0))):
        d = np.empty((48, 64), np.uint8)
        box_difference(flat, bg, 5, taps, d)
        out[name] = d.astype(float)
    raw = np.empty((48, 64), np.uint8)
    difference(flat, bg, True, raw)
    difference(flat, bg, False, raw)
    flat_noise = {n: d[:, 5:25].std() for n, d in out.items()}
    assert flat_noise["gauss"] < raw[:, 5:25].astype(float).std()
    step = {n: d[:, 32:34].mean() - d[:, 30:32].mean() for n, d in out.items()}
    assert step["gauss"] > step["box"]


def test_threshold_and_opening_are_opencvs():
    rng = np.random.default_rng(7)
    d = rng.integers(0, 40, (48, 64), dtype=np.uint8)
    d[10:20, 10:30] = 90
    for t in (12.0, 20.7, 35.0):
        got = np.empty_like(d)
        open2(d, math.floor(t), got)
        mask = cv2.threshold(d, t, 255, cv2.THRESH_BINARY)[1]
        expect = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((2, 2), np.uint8))
        np.testing.assert_array_equal(got, expect)


@pytest.mark.parametrize("shape", [(60, 80), (9, 13)])
def test_window_background_is_opencv_bilinear_upscaling_by_8(shape):
    """The refinement's background of a window (integer tables, 16-bit rows) is what
    ``cv2.resize`` (bilinear) of the whole 1/8-scale estimate gives there."""
    from cell.vision._segment_kernel import upscale_axis
    from cell.vision._upscale_kernel import window_background

    hs, ws = shape
    rng = np.random.default_rng(hs)
    small = rng.integers(0, 256, (hs, ws, 3), dtype=np.uint8)
    small[: hs // 2, : ws // 2] = 255  # saturation and flat areas
    full = cv2.resize(small, (8 * ws, 8 * hs), interpolation=cv2.INTER_LINEAR)
    rows, cols = upscale_axis(hs, 8 * hs, False), upscale_axis(ws, 8 * ws, True)
    for x0, y0, x1, y1 in ((0, 0, 8 * ws, 8 * hs), (3, 5, 40, 33), (8 * ws - 9, 8 * hs - 7,
                                                                      8 * ws, 8 * hs)):
        h, w = y1 - y0, x1 - x0
        inter = np.empty((hs, 3 * w), np.uint16)
        got = np.empty((h, 3 * w), np.uint8)
        window_background(small, rows, cols, x0, y0, h, w, inter, np.empty((2, w), np.uint64),
                          np.empty((2, w), np.uint16), got)
        np.testing.assert_array_equal(got.reshape(h, w, 3), full[y0:y1, x0:x1])


def test_window_dilation_is_opencv_dilate_with_columns_doubled():
    """The refinement's 3x3 dilation of a window of the framed half-scale mask is
    ``cv2.dilate`` there (the frame empty), each column twice (at full scale)."""
    from cell.vision._mosaic import _dilated

    rng = np.random.default_rng(3)
    near = np.zeros((30, 40), np.uint8)
    near[1:-1, 1:-1] = rng.random((28, 38)) < 0.1
    full = cv2.dilate(near, np.ones((3, 3), np.uint8))
    for x0, y0, w, h in ((0, 0, 38, 28), (5, 7, 20, 11), (37, 27, 1, 1)):
        out = np.full((h, 2 * w), 7, np.uint8)
        _dilated(near, x0, y0, w, h, np.empty((h + 2, w), np.uint8), out)
        expect = np.repeat(full[y0 + 1 : y0 + 1 + h, x0 + 1 : x0 + 1 + w], 2, axis=1)
        np.testing.assert_array_equal(out, expect)
