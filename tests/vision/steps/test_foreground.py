"""Step 1: the belt model, the colour difference and the segmentation methods."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cell.errors import VisionError
from cell.vision.settings import SEGMENTATIONS, VisionSettings
from cell.vision.steps.foreground import (
    belt_model,
    belt_scale,
    colour_difference,
    find_foreground,
    grey_step,
    impulse_share,
    noise_sigma,
)
from tests.vision.steps import drawn


def test_the_belt_median_in_a_window_is_the_whole_model_resized_there():
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
    for scale in (8, 16):
        model = belt_model(image, scale=scale)
        whole = model.at((640, 480))
        for x0, y0, x1, y1 in ((0, 0, 37, 21), (100, 50, 180, 130), (601, 455, 640, 480), (8, 8, 9, 9)):
            np.testing.assert_array_equal(model.median_in(x0, y0, x1, y1), whole.median[y0:y1, x0:x1])


def test_no_difference_on_the_belt_nor_where_it_meets_the_table():
    img = drawn.frame()
    img[300:] = (150, 148, 140)  # the table below the belt's edge
    cv2.circle(img, drawn.mm(-60, 20), drawn.px(10), (200, 60, 50), -1)  # a red part
    belt = belt_model(img).at((640, 480))
    diff = colour_difference(img, belt.low, belt.high)
    assert np.percentile(diff[280:320], 99) <= 6  # the edge: within the model's range
    u, v = drawn.mm(-60, 20)
    assert diff[v, u] > 80


def test_colour_difference_is_the_largest_channel_outside_the_range():
    rng = np.random.default_rng(2)
    for shape in ((480, 640, 3), (7, 5, 3), (1, 1, 3)):
        img, low = (rng.integers(0, 256, shape, dtype=np.uint8) for _ in range(2))
        high = np.maximum(low, rng.integers(0, 256, shape, dtype=np.uint8))
        i = img.astype(int)
        want = np.maximum(np.clip(i - high, 0, None), np.clip(low - i, 0, None)).max(axis=2)
        np.testing.assert_array_equal(colour_difference(img, low, high), want)


def test_the_belt_model_ignores_the_parts():
    img = drawn.frame()
    for x in (-100, -40, 20, 80):
        cv2.circle(img, drawn.mm(x, 0), drawn.px(15), (230, 230, 230), -1)
    model = belt_model(img).at((640, 480))
    assert np.abs(model.median.astype(int) - drawn.BELT).max() <= 3


@pytest.mark.parametrize("method", SEGMENTATIONS)
def test_every_segmentation_finds_a_bright_part(method):
    img = drawn.frame()
    cv2.circle(img, drawn.mm(0, 0), drawn.px(12), (220, 220, 215), -1)
    fg = find_foreground(img, VisionSettings(segmentation=method, threshold=150))
    u, v = drawn.mm(0, 0)
    assert fg.mask[v, u] == 255 and fg.mask[10, 10] == 0
    assert cv2.countNonZero(fg.mask) == pytest.approx(np.pi * drawn.px(12) ** 2, rel=0.2)


def test_fixed_threshold_above_the_part_finds_nothing():
    img = drawn.frame()
    cv2.circle(img, drawn.mm(0, 0), drawn.px(12), (120, 120, 120), -1)
    fg = find_foreground(img, VisionSettings(segmentation="fixed", threshold=150))
    assert cv2.countNonZero(fg.mask) == 0


def test_a_light_table_is_backlit_and_parts_are_its_dark_silhouettes():
    img = np.full((480, 640, 3), 250, np.uint8)
    cv2.circle(img, drawn.mm(0, 0), drawn.px(12), (20, 20, 20), -1)
    for method in ("belt", "otsu"):
        fg = find_foreground(img, VisionSettings(segmentation=method))
        u, v = drawn.mm(0, 0)
        assert fg.backlit and fg.mask[v, u] == 255 and fg.mask[10, 10] == 0


def test_a_noisy_frame_is_smoothed_first():
    img = np.clip(drawn.frame().astype(np.float64) + np.random.default_rng(1).normal(0, 8, (480, 640, 3)),
                  0, 255).astype(np.uint8)
    fg = find_foreground(img, VisionSettings())
    assert fg.image is not img and fg.noise > 2
    assert cv2.countNonZero(fg.mask) < 0.001 * img.shape[0] * img.shape[1]  # no noise specks


def _noisy(img: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    """``img`` plus Gaussian noise of ``sigma`` grey levels, rounded and saturated."""
    noise = np.random.default_rng(seed).normal(0, sigma, img.shape)
    return np.clip(np.rint(img.astype(np.float64) + noise), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("sigma, aperture", [(8, 3), (40, 7), (60, 11), (90, 15)])
def test_the_smoothing_widens_with_the_sensor_noise(sigma, aperture):
    """The smallest Gaussian from vision.smooth (3) up to 15x15 that leaves under 8.5 grey
    levels of the noise as the frame's estimate reads it (57.7 for 60: the sensor clips
    some): 3x3 leaves 0.375 of it, 7x7 0.201, 11x11 0.143; 15x15 at most."""
    img = _noisy(drawn.frame(), sigma, 2)
    assert np.array_equal(find_foreground(img, VisionSettings()).image,
                          cv2.GaussianBlur(img, (aperture, aperture), 0))
    wider = find_foreground(img, VisionSettings(smooth=max(aperture, 9))).image
    assert np.array_equal(wider, cv2.GaussianBlur(img, (max(aperture, 9),) * 2, 0))  # the least


@pytest.mark.parametrize("seed", range(3))
def test_a_grey_part_under_heavy_noise_is_found_whole(seed):
    """A grey plastic disc (20 mm; 55 grey levels over the belt in red, 7 in blue) under
    noise of sigma 40: a 3x3 Gaussian left 15 grey levels of it and kept 29-67 % of the disc;
    the 7x7 the noise asks for keeps most of it, and no speck of the belt grows to half a part."""
    img = drawn.frame().astype(np.float64)
    part = np.zeros(img.shape[:2], np.uint8)
    cv2.circle(part, drawn.mm(0, 0), drawn.px(10), 1, -1)
    img[part > 0] = (115, 115, 117)
    fg = find_foreground(_noisy(img, 40, seed), VisionSettings())
    assert (fg.mask[part > 0] > 0).mean() > 0.85
    n, labels, stats, _ = cv2.connectedComponentsWithStats(fg.mask)
    disc = labels[drawn.mm(0, 0)[1], drawn.mm(0, 0)[0]]
    specks = [stats[i, cv2.CC_STAT_AREA] for i in range(1, n) if i != disc]
    assert max(specks, default=0) < 0.5 * part.sum()


def test_impulse_share_counts_lone_black_and_white_pixels_on_every_8th_row():
    img = np.full((64, 64, 3), 100, np.uint8)  # rows 4, 12, ..., 60 sampled: 8 x 62 pixels
    for x in (10, 20, 30):
        img[4, x] = 255  # white: counted
    img[12, 40] = 0  # black: counted
    img[20, 50:52] = 255  # a pair (a glare spot's edge): neither is alone
    img[28, 9] = (255, 255, 0)  # saturated in two channels: no impulse
    img[5, 30] = 0  # not a sampled row
    assert impulse_share(img) == pytest.approx(4 / (8 * 62))
    assert impulse_share(img[:4]) == 0.0 and impulse_share(img[:, :2]) == 0.0
    with pytest.raises(VisionError, match="image"):
        impulse_share(img[..., 0])


@pytest.mark.parametrize("seed", range(2))
def test_salt_and_pepper_is_taken_out_by_a_median_first(seed):
    """10 % of the pixels black or white (a sensor's dead and hot pixels): the frame's 3x3
    median is segmented, and the grey disc is found whole with no speck of the belt."""
    rng = np.random.default_rng(seed)
    img = drawn.frame()
    part = np.zeros(img.shape[:2], np.uint8)
    cv2.circle(part, drawn.mm(0, 0), drawn.px(10), 1, -1)
    img[part > 0] = (115, 115, 117)
    hit = rng.random(img.shape[:2]) < 0.10
    img[hit] = (rng.integers(0, 2, int(hit.sum())) * 255).astype(np.uint8)[:, None]
    fg = find_foreground(img, VisionSettings())
    assert 0.08 < fg.impulses < 0.11
    assert (fg.mask[part > 0] > 0).mean() > 0.95
    assert cv2.countNonZero(fg.mask) - cv2.countNonZero(fg.mask * part) < 20
    few = img.copy()
    few[hit] = drawn.frame()[hit]
    few[part > 0] = (115, 115, 117)
    few[4, 100], few[12, 200] = 255, 0  # a few hot and dead pixels: no median
    clean = find_foreground(few, VisionSettings())
    assert 0 < clean.impulses < 0.04 and clean.image is few
    unsmoothed = find_foreground(img, VisionSettings(smooth=0))  # no smoothing of any kind
    assert unsmoothed.impulses == fg.impulses and unsmoothed.image is img


def test_grey_step_reads_the_bits_a_sensor_kept():
    img = _noisy(drawn.frame(), 6, 0)
    assert grey_step(img) == 1
    for bits in (7, 4, 2):
        step = 1 << (8 - bits)
        quantised = img & np.uint8(256 - step)
        assert grey_step(quantised) == step
        quantised[4::8][:, ::150] = 255  # a few hot pixels (under 1 %) do not hide it
        assert grey_step(quantised) == step and grey_step(quantised[..., 0]) == step
    assert grey_step(img[:4]) == 1  # no row 4: nothing to read
    with pytest.raises(VisionError, match="image"):
        grey_step(img.astype(np.float32))


def test_a_step_as_coarse_as_a_contrast_sets_no_floor():
    """From 2 bits (steps of 64) a step is as large as the contrasts to be seen: a drawn
    frame of black and 128 (step 128) keeps the belt floor of 8, not 192."""
    img = np.zeros((240, 320, 3), np.uint8)
    cv2.circle(img, (160, 120), 30, (128, 128, 128), -1)
    fg = find_foreground(img, VisionSettings())
    assert grey_step(img) == 128 and fg.threshold == 8.0
    assert cv2.countNonZero(fg.mask) > 0.95 * np.pi * 30**2


def test_quantisation_bands_are_no_foreground():
    """A 4-bit sensor (steps of 16 grey levels) under a light that falls off across the
    belt: the belt is bands of flat colour, whose edges stand a full step off the belt
    model; at the frame's own noise level (none left: 8, the floor) they were 500-odd
    specks and the bolt lay among them. The threshold stands at 1.5 steps at least."""
    img = drawn.frame().astype(np.float64) * np.linspace(0.7, 1.3, 640)[None, :, None]
    part = np.zeros(img.shape[:2], np.uint8)
    cv2.rectangle(part, drawn.mm(-5, -20), drawn.mm(5, 20), 1, -1)  # a blue plastic bar
    img[part > 0] = (11, 40, 160)
    img = _noisy(img, 1.5, 3) & np.uint8(0xF0)
    fg = find_foreground(img, VisionSettings())
    assert fg.threshold == 24.0
    assert (fg.mask[part > 0] > 0).mean() > 0.95
    assert cv2.countNonZero(fg.mask) - cv2.countNonZero(fg.mask * part) < 20


def test_a_noisy_frame_keeps_more_of_a_faint_part_by_hysteresis():
    """Sensor noise (sigma 8) raises the threshold to 8.9 grey levels; a part 8 over the
    belt is then broken (45 % of it foreground) unless the pixels over 0.8 of the threshold
    that touch one over it count (61 %); the belt's own noise stays no foreground."""
    rng = np.random.default_rng(1)
    img = drawn.frame().astype(np.float64) + rng.normal(0, 8, (480, 640, 3))
    part = np.zeros((480, 640), np.uint8)
    cv2.rectangle(part, drawn.mm(30, 6), drawn.mm(42, -6), 1, -1)
    img[part > 0] += 8
    img = np.clip(img, 0, 255).astype(np.uint8)
    fg, plain = (find_foreground(img, VisionSettings(belt_low=b)) for b in (0.8, 1.0))
    assert fg.noise > 2 and fg.threshold == pytest.approx(8.9, abs=0.5)
    with_, without = ((m.mask[part > 0] > 0).mean() for m in (fg, plain))
    assert with_ > 0.55 and with_ > 1.3 * without
    belt = cv2.countNonZero(fg.mask) - cv2.countNonZero(fg.mask * part)
    assert belt < 0.001 * img.shape[0] * img.shape[1]


def test_a_clean_frame_is_thresholded_without_hysteresis():
    """No sensor noise: the threshold is the floor (8) and a rim 7 over the belt around a
    clear part is no foreground, whatever ``belt_low``."""
    img = np.empty((480, 640, 3), np.uint8)
    img[:] = drawn.BELT
    cv2.circle(img, drawn.mm(-40, 0), drawn.px(12), tuple(c + 7 for c in drawn.BELT), -1)
    cv2.circle(img, drawn.mm(-40, 0), drawn.px(6), (200, 200, 195), -1)
    masks = [find_foreground(img, VisionSettings(belt_low=b)).mask for b in (0.8, 1.0)]
    u, v = drawn.mm(-40 + 9, 0)  # on the rim
    assert not masks[0][v, u]
    np.testing.assert_array_equal(masks[0], masks[1])


@pytest.mark.parametrize("image", [np.zeros((48, 64, 3), np.float32), np.zeros((48, 64), np.uint8),
                                   np.zeros((48, 64, 4), np.uint8), [[0, 1], [2, 3]]])
@pytest.mark.parametrize("call", [
    lambda img: find_foreground(img, VisionSettings()),
    lambda img: belt_model(img),
    lambda img: noise_sigma(img),
    lambda img: colour_difference(img, img, img),
])
def test_the_steps_refuse_what_is_not_a_uint8_rgb_frame(image, call):
    with pytest.raises(VisionError, match="argument 'image'"):
        call(image)


def test_colour_difference_wants_one_shape():
    a, b = np.zeros((8, 8, 3), np.uint8), np.zeros((8, 9, 3), np.uint8)
    with pytest.raises(VisionError, match="one shape"):
        colour_difference(a, a, b)


def test_the_belt_model_is_at_least_72_mm_wide_on_the_table_however_fine_the_pixels():
    assert belt_scale(None) == 8 and belt_scale(0.000607) == 8  # the default camera's pixels
    assert belt_scale(0.000303) == 16 and belt_scale(0.0012) == 8  # 1280x960; 320x240
    for m_per_px in np.linspace(0.0001, 0.0006, 26):  # never under 72 mm (rounding gave 70)
        assert belt_scale(m_per_px) * 15 * m_per_px >= 0.072 - 1e-12
    with pytest.raises(VisionError, match="argument 'm_per_px'"):
        belt_scale(0.0)


def test_a_part_as_wide_as_the_default_window_stays_whole_in_a_fine_frame():
    # 1280x960 at 0.3 mm a pixel: a 30 mm disc is 100 px wide, most of a 120 px median's
    # window, whose middle the median then took for belt (the disc lost its middle)
    img = np.empty((960, 1280, 3), np.uint8)
    img[:] = drawn.BELT
    cv2.circle(img, (640, 480), 50, (230, 230, 230), -1)
    coarse = find_foreground(img, VisionSettings())  # (None: the default camera's 8)
    fine = find_foreground(img, VisionSettings(), m_per_px=0.0003)
    assert coarse.mask[480, 640] == 0  # the old failure, kept as the reason
    assert fine.mask[430:531, 590:691][_disc(50)].all()


def _disc(r: int) -> np.ndarray:
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    return xx**2 + yy**2 <= (r - 2) ** 2


@pytest.mark.parametrize("method", ["otsu", "iterative"])
def test_a_one_level_light_table_has_no_foreground(method):
    """One grey level has no two classes: Otsu's threshold is the level, which on a light
    table (dark polarity, image <= t) made the whole frame foreground."""
    frame = np.full((120, 160, 3), 230, np.uint8)
    fg = find_foreground(frame, VisionSettings(segmentation=method))
    assert fg.backlit and not fg.mask.any()


def test_a_bright_coloured_belt_is_not_a_light_table():
    """Bright but saturated (yellow): not back-lit, so a dark part is not taken as a
    silhouette of the light table, and a bright part on it is still found by Otsu."""
    img = np.full((480, 640, 3), (250, 230, 40), np.uint8)
    cv2.circle(img, drawn.mm(0, 0), drawn.px(12), (255, 255, 255), -1)
    fg = find_foreground(img, VisionSettings(segmentation="otsu"))
    u, v = drawn.mm(0, 0)
    assert not fg.backlit
    assert fg.mask[v, u] == 255 and fg.mask[10, 10] == 0


def test_noise_sigma_recovers_the_sensor_noise():
    """Gaussian noise of sigma 6 grey levels on a flat grey frame measures as about 6
    (differences of two pixels have sigma 6 sqrt 2; the estimate divides it back)."""
    rng = np.random.default_rng(4)
    img = np.clip(128 + rng.normal(0, 6, (480, 640, 3)), 0, 255).astype(np.uint8)
    assert noise_sigma(img) == pytest.approx(6.0, rel=0.1)
