"""The sensor model's noise, salt and pepper and bit depth, and the segmentation id mapping.

Statistics are checked on a flat grey frame, where the delivered image minus the grey
level is the noise itself. Tolerances are several standard errors wide; no test is timed.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from cell.errors import SimError
from cell.sim.cameras import part_ids, part_lut
from cell.sim.sensor import (
    BANK_FRAMES,
    BANK_SCALE,
    SensorModel,
    add_noise,
    draw_noise_bank,
    noise_run,
    quantise,
    salt_and_pepper,
)

H, W = 480, 640
GREY = 128
K = np.array([[500.0, 0.0, (W - 1) / 2], [0.0, 500.0, (H - 1) / 2], [0.0, 0.0, 1.0]])
GEOM, SITE = int(mujoco.mjtObj.mjOBJ_GEOM), int(mujoco.mjtObj.mjOBJ_SITE)


def _grey() -> np.ndarray:
    return np.full((H, W, 3), GREY, np.uint8)


def _noise(frame: np.ndarray) -> np.ndarray:
    """A delivered grey frame's noise, float64 (H, W, 3), grey levels."""
    return frame.astype(np.float64) - GREY


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.corrcoef(a.ravel(), b.ravel())[0, 1])


def _frames(n: int, *, sigma: float = 20.0, gain: float = 1.0, seed: int = 1, **settings):
    model = SensorModel(K, W, H, noise_std=sigma, **settings)
    rng = np.random.default_rng(seed)
    return [model.apply(_grey(), rng, gain=gain) for _ in range(n)]


# --- noise ------------------------------------------------------------------------------

def test_a_noise_run_is_unit_gaussian_before_rounding():
    rng = np.random.default_rng(3)
    bank = draw_noise_bank(H * W * 3, rng)
    assert bank.dtype == np.int16 and bank.size == BANK_FRAMES * H * W * 3
    run, sign = noise_run(bank, H * W * 3, rng)
    z = sign * run.astype(np.float64) / BANK_SCALE
    assert abs(z.mean()) < 0.005  # standard error 0.001
    assert abs(z.std() - 1.0) < 0.005  # standard error 0.0007


@pytest.mark.parametrize("gain", [1.0, 2.5])
def test_noise_has_mean_zero_and_std_noise_std_times_gain(gain):
    sigma = 8.0  # grey 128 +- 6 sigma stays inside 0..255: no saturation
    noise = _noise(_frames(1, sigma=sigma, gain=gain)[0])
    expected = np.hypot(sigma * gain, np.sqrt(1 / 12))  # rounding adds 1/12 grey level^2
    assert abs(noise.mean()) < 0.05
    assert abs(noise.std() / expected - 1) < 0.01


def test_default_noise_std_survives_rounding():
    noise = _noise(_frames(1, sigma=1.5)[0])
    assert abs(noise.mean()) < 0.02
    assert abs(noise.std() - np.hypot(1.5, np.sqrt(1 / 12))) < 0.02


def test_consecutive_frames_noise_is_uncorrelated():
    frames = [_noise(f) for f in _frames(6)]
    for a, b in zip(frames, frames[1:], strict=False):
        assert abs(_corr(a, b)) < 0.02  # standard error 0.001


def test_neighbouring_pixels_and_channels_are_uncorrelated():
    noise = _noise(_frames(1)[0])
    assert abs(_corr(noise[:, 1:], noise[:, :-1])) < 0.01  # left-right
    assert abs(_corr(noise[1:], noise[:-1])) < 0.01  # up-down
    assert abs(_corr(noise[..., 0], noise[..., 1])) < 0.01  # red-green of one pixel


def test_averaging_frames_divides_the_noise_by_sqrt_n():
    n = 16
    mean = np.mean([_noise(f) for f in _frames(n)], axis=0)
    single = np.hypot(20.0, np.sqrt(1 / 12))
    assert abs(mean.std() / (single / np.sqrt(n)) - 1) < 0.02


def test_gain_change_scales_the_same_bank():
    model = SensorModel(K, W, H, noise_std=4.0)
    rng = np.random.default_rng(5)
    low = _noise(model.apply(_grey(), rng, gain=1.0)).std()
    high = _noise(model.apply(_grey(), rng, gain=3.0)).std()
    assert abs(high / low - np.hypot(12, 0.29) / np.hypot(4, 0.29)) < 0.03


def test_same_generator_state_gives_the_same_images():
    settings = {"sigma": 3.0, "salt_pepper": 0.01, "bits": 6}
    a, b = _frames(3, seed=7, **settings), _frames(3, seed=7, **settings)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    c = _frames(3, seed=8, **settings)
    assert not np.array_equal(a[0], c[0])


def test_no_noise_and_nothing_else_returns_the_render_untouched():
    rgb = _grey()
    model = SensorModel(K, W, H, noise_std=0.0)
    assert model.apply(rgb, np.random.default_rng(0)) is rgb
    brighter = rgb + 7
    out = SensorModel(K, W, H, noise_std=0.0, bits=4).apply(brighter, np.random.default_rng(0))
    assert np.all(out == GREY) and np.all(brighter == GREY + 7)  # the input is left as it was


def test_apply_rejects_a_frame_of_another_size_or_type_and_a_bad_gain():
    model = SensorModel(K, W, H, noise_std=1.0)
    rng = np.random.default_rng(0)
    with pytest.raises(SimError, match="uint8"):
        model.apply(np.zeros((H, W, 3), np.float32), rng)
    with pytest.raises(SimError, match="uint8"):
        model.apply(np.zeros((H // 2, W, 3), np.uint8), rng)
    with pytest.raises(SimError, match="gain"):
        model.apply(_grey(), rng, gain=float("nan"))


@pytest.mark.parametrize("call", [
    lambda img, rng: quantise(img, 4),
    lambda img, rng: add_noise(img, draw_noise_bank(64, rng), 1.0, rng),
    lambda img, rng: salt_and_pepper(img, 0.1, rng),
])
@pytest.mark.parametrize("image", [np.zeros((4, 5, 3), np.float32), np.zeros((0, 5, 3), np.uint8),
                                   [[1, 2], [3, 4]]])
def test_the_sensor_steps_refuse_what_is_not_a_uint8_image(call, image):
    with pytest.raises(SimError, match=r"^(quantise|add_noise|salt_and_pepper): expected a uint8"):
        call(image, np.random.default_rng(0))


@pytest.mark.parametrize("bits", [0, 9, 2.5, True, "8"])
def test_quantise_takes_1_to_8_bits(bits):
    with pytest.raises(SimError, match="bits must be an integer 1 to 8"):
        quantise(np.zeros((2, 2, 3), np.uint8), bits)


# --- salt and pepper, bit depth ---------------------------------------------------------------

def test_salt_and_pepper_hits_the_fraction_of_whole_pixels_half_white():
    p = 0.01
    frame = _frames(1, sigma=0.0, salt_pepper=p)[0]
    white = np.all(frame == 255, axis=2)
    black = np.all(frame == 0, axis=2)
    hit = white | black
    assert np.all(frame[~hit] == GREY)  # a hit pixel is hit in every channel
    se = np.sqrt(p * (1 - p) / (H * W))
    assert abs(hit.mean() - p) < 5 * se
    assert abs(white.sum() / hit.sum() - 0.5) < 0.05


@pytest.mark.parametrize("bits", [1, 4, 7])
def test_bit_depth_keeps_the_top_bits(bits):
    ramp = np.broadcast_to(np.arange(256, dtype=np.uint8)[None, :256, None], (H, 256, 3))
    rgb = np.zeros((H, W, 3), np.uint8)
    rgb[:, :256] = ramp
    out = SensorModel(K, W, H, bits=bits).apply(rgb, np.random.default_rng(0))
    step = 1 << (8 - bits)
    assert np.array_equal(out, (rgb // step) * step)
    assert len(np.unique(out)) == 1 << bits


def test_bit_depth_after_noise_gives_only_its_levels():
    frame = _frames(1, sigma=20.0, bits=4)[0]
    levels = np.unique(frame)
    assert np.all(levels % 16 == 0) and len(levels) > 4


# --- segmentation id mapping ------------------------------------------------------------------

def _reference_part_ids(raw: np.ndarray, part_of_geom: np.ndarray) -> np.ndarray:
    """The straightforward mapping: masks and np.where."""
    obj, kind = raw[..., 0], raw[..., 1]
    is_geom = (kind == GEOM) & (obj >= 0) & (obj < len(part_of_geom))
    return np.where(is_geom, part_of_geom[np.clip(obj, 0, len(part_of_geom) - 1)], 0).astype(np.int32)


def _synthetic_raw(ngeom: int) -> np.ndarray:
    """A raw segmentation (H, W, 2) with geoms, sites, other objects and background."""
    rng = np.random.default_rng(11)
    obj = rng.integers(0, ngeom, (H, W)).astype(np.int32)
    kind = np.full((H, W), GEOM, np.int32)
    site = rng.random((H, W)) < 0.2
    kind[site] = SITE
    obj[site] = rng.integers(0, ngeom + 50, site.sum())  # sites share (and pass) geom ids
    body = rng.random((H, W)) < 0.05
    kind[body], obj[body] = int(mujoco.mjtObj.mjOBJ_BODY), 3
    odd = rng.random((H, W)) < 0.02  # negative id with the type just below a geom's
    kind[odd], obj[odd] = GEOM - 1, -1
    background = rng.random((H, W)) < 0.1
    kind[background] = obj[background] = -1
    return np.stack([obj, kind], axis=-1)


@pytest.mark.parametrize("little_endian", [True, False])
def test_id_mapping_matches_the_reference(little_endian):
    ngeom = 120
    part_of_geom = np.zeros(ngeom, np.int32)
    part_of_geom[0] = 9  # geom 0 is a part: background and sites must not land there
    part_of_geom[100:110] = np.arange(1, 11)
    part_of_geom[ngeom - 1] = 12  # so is the last geom
    raw = _synthetic_raw(ngeom)
    if not little_endian:  # the arithmetic path (big-endian CPUs) runs anywhere
        got = part_ids(raw, part_lut(part_of_geom), little_endian=False)
    else:
        got = part_ids(raw, part_lut(part_of_geom))
    expected = _reference_part_ids(raw, part_of_geom)
    assert got.dtype == np.int32 and got.shape == (H, W)
    assert np.array_equal(got, expected)
    assert set(np.unique(expected)) >= {0, 9, 12, 1, 10}


def test_id_mapping_of_background_and_sites_only_is_zero():
    part_of_geom = np.arange(1, 21, dtype=np.int32)  # every geom a part
    raw = np.full((4, 5, 2), -1, np.int32)
    raw[0] = (3, SITE)
    raw[1, :, 0], raw[1, :, 1] = np.arange(5), SITE
    raw[2] = (19, GEOM)
    assert np.array_equal(part_ids(raw, part_lut(part_of_geom))[[0, 1, 3]], np.zeros((3, 5)))
    assert np.all(part_ids(raw, part_lut(part_of_geom))[2] == 20)


def test_a_barrel_lens_samples_beyond_the_pinhole_view():
    """[-0.2, 0.05, 0, 0, 0] at a 40-degree field of view sees 27 px beyond the pinhole
    view at the corners: the model asks for a render that much larger on each side and
    samples it where the lens looks (the edge pixels were repeated over 9 % of the image)."""
    import cv2

    f = 0.5 * H / np.tan(np.radians(20.0))
    K40 = np.array([[f, 0.0, (W - 1) / 2], [0.0, f, (H - 1) / 2], [0.0, 0.0, 1.0]])
    dist = (-0.2, 0.05, 0.0, 0.0, 0.0)
    model = SensorModel(K=K40, width=W, height=H, distortion=dist)
    px, py = model.padding()
    assert px >= 27 and py >= 20
    ideal_x = np.tile(np.arange(W + 2 * px, dtype=np.float32) - px, (H + 2 * py, 1))
    seen = model.warp(ideal_x)  # what each pixel sees: the ideal x it samples
    corner = cv2.undistortPointsIter(np.array([[[0.0, 0.0]]]), K40, np.array(dist), None, K40,
                                     (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12))
    assert seen.shape == (H, W) and corner[0, 0, 0] < -10
    assert seen[0, 0] == pytest.approx(corner[0, 0, 0], abs=0.04)  # (remap: 1/32 px steps)
    with pytest.raises(SimError, match="expected an ideal render of"):
        model.warp(np.zeros((H, W), np.float32))


def test_a_lens_model_that_folds_the_image_is_a_sim_error():
    f = 0.5 * H / np.tan(np.radians(30.0))
    K60 = np.array([[f, 0.0, (W - 1) / 2], [0.0, f, (H - 1) / 2], [0.0, 0.0, 1.0]])
    for dist in ((-0.3, 0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0, 1.0, 0.0)):
        with pytest.raises(SimError, match="the lens model folds the image"):
            SensorModel(K=K60, width=W, height=H, distortion=dist).padding()


def test_a_noise_run_may_take_the_whole_bank_and_its_last_values():
    """Offsets are uniform over 0..len(bank) - values inclusive: a run as long as the
    bank is the bank, and the last value is reachable."""
    bank = np.arange(10, dtype=np.int16)
    rng = np.random.default_rng(0)
    run, sign = noise_run(bank, 10, rng)
    np.testing.assert_array_equal(run, bank)
    assert sign in (1.0, -1.0)
    starts = {int(noise_run(bank, 3, rng)[0][0]) for _ in range(400)}
    assert starts == set(range(8))


def test_add_noise_flips_the_sign_of_the_run_half_the_time():
    """A bank of +1 unit values and sigma 10: each frame is the image +10 or -10 grey
    levels, both signs occurring (the sign doubles the distinct noise patterns)."""
    bank = np.full(12, BANK_SCALE, np.int16)
    img = np.full((2, 2, 3), 100, np.uint8)
    rng = np.random.default_rng(5)
    seen = {int(add_noise(img, bank, 10.0, rng)[0, 0, 0]) for _ in range(32)}
    assert seen == {90, 110}


def test_a_lens_that_sees_beyond_half_the_image_is_a_sim_error():
    """(-0.1, 0.005) at a 90-degree field on a 64 x 48 sensor does not fold but would need
    a render padded by more than half the image on each side: refused, saying so."""
    H, W = 48, 64
    f = 0.5 * H / np.tan(np.radians(45.0))
    K = np.array([[f, 0.0, (W - 1) / 2], [0.0, f, (H - 1) / 2], [0.0, 0.0, 1.0]])
    with pytest.raises(SimError, match="more than half the image"):
        SensorModel(K=K, width=W, height=H, distortion=(-0.1, 0.005, 0.0, 0.0, 0.0)).padding()
