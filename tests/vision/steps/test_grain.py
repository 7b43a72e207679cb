"""The grain cue: a surface's brightness grain measured free of the sensor's noise."""

from __future__ import annotations

import numpy as np
import pytest

from cell.vision.steps.grain import GrainCues, grain_cues, interior_statistics


def _surface(*, grain: float, noise: float, seed: int, size: int = 48,
             colour=(150.0, 140.0, 120.0)) -> np.ndarray:
    """uint8 (size, size, 3): a flat colour whose brightness varies pixel to pixel by a
    factor of relative spread ``grain`` (the same in every channel), plus independent
    Gaussian noise of ``noise`` grey levels in each channel."""
    rng = np.random.default_rng(seed)
    shade = 1.0 + grain * rng.normal(size=(size, size, 1))
    img = np.array(colour) * shade + rng.normal(0.0, noise, (size, size, 3))
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def _full(patch: np.ndarray) -> np.ndarray:
    return np.full(patch.shape[:2], 255, np.uint8)


def test_statistics_count_and_average_the_masked_pixels_only():
    patch = _surface(grain=0.0, noise=2.0, seed=1)
    patch[:, :10] = 255  # saturated, outside the mask
    mask = _full(patch)
    mask[:, :10] = 0
    mask[0, 20] = 0
    inner = interior_statistics(patch, mask)
    inside = patch[mask > 0].astype(np.float64)
    assert inner.pixels == len(inside)
    np.testing.assert_allclose(inner.mean_rgb, inside.mean(axis=0), atol=1e-9)
    assert inner.unclipped == len(inside)  # the saturated columns are outside
    # about half the pixels are both flatter and brighter than the medians' (they correlate)
    assert 0.2 * inner.pixels <= inner.grain_pixels <= 0.55 * inner.pixels


def test_saturated_pixels_inside_are_counted_clipped():
    patch = _surface(grain=0.0, noise=2.0, seed=2)
    patch[:5] = (255, 10, 10)
    inner = interior_statistics(patch, _full(patch))
    assert inner.pixels - inner.unclipped == 5 * patch.shape[1]


def _cues(*, grain: float, noise: float, seed: int) -> GrainCues:
    p = _surface(grain=grain, noise=noise, seed=seed)
    return grain_cues([interior_statistics(p, _full(p))], noise)


@pytest.mark.parametrize("seed", range(3))
def test_grain_is_measured_through_sensor_noise(seed):
    """The grain read grows in proportion to the surface's and does not grow with the
    sensor's noise; it stands clearly above its standard error; a smooth surface under the
    same noise reads no grain and no evidence of any."""
    fine, coarse = (_cues(grain=g, noise=3.0, seed=seed) for g in (0.03, 0.06))
    assert 1.7 < coarse.amplitude[0] / fine.amplitude[0] < 2.3
    noisier = _cues(grain=0.06, noise=6.0, seed=seed)
    assert abs(noisier.amplitude[0] / coarse.amplitude[0] - 1.0) < 0.2
    assert fine.z[0] > 5 and coarse.z[0] > 5
    smooth = _cues(grain=0.0, noise=3.0, seed=seed)
    assert smooth.amplitude[0] < 0.1 * coarse.amplitude[0] and smooth.z[0] < 3
    assert smooth.visibility[0] > 4  # a metal's grain would show here: its absence counts


def test_per_channel_noise_is_not_grain_however_strong():
    """Noise independent in each channel (the sensor's) reads as noise, not grain, at any
    level: its share along the colour is matched by the share across it."""
    for noise in (2.0, 8.0, 20.0):
        p = _surface(grain=0.0, noise=noise, seed=7)
        cues = grain_cues([interior_statistics(p, _full(p))], noise)
        assert cues.z[0] < 3, noise


def test_the_frames_noise_floors_the_surfaces_own_estimate():
    """A frame known to be noisier than the part's pixels suggest lowers the grain."""
    p = _surface(grain=0.04, noise=1.0, seed=3)
    inner = interior_statistics(p, _full(p))
    quiet, noisy = grain_cues([inner], 0.0), grain_cues([inner], 6.0)
    assert noisy.amplitude[0] < quiet.amplitude[0] and noisy.z[0] < quiet.z[0]


def test_cues_are_per_part_and_unseen_keeps_no_evidence():
    parts = [_surface(grain=g, noise=2.0, seed=4) for g in (0.0, 0.06)]
    cues = grain_cues([interior_statistics(p, _full(p)) for p in parts], 2.0)
    assert isinstance(cues, GrainCues) and cues.amplitude.shape == (2,)
    assert cues.amplitude[0] < cues.amplitude[1]
    blind = cues.unseen()
    assert not blind.z.any() and not blind.visibility.any()
    np.testing.assert_array_equal(blind.amplitude, cues.amplitude)
