"""Material classifier: grain separates metal from plastic whatever the colour and noise."""

from __future__ import annotations

import numpy as np
import pytest

from cell.catalogue import MATERIALS
from cell.errors import VisionError
from cell.vision.material import classify_material, material_features

BELT = (0.22, 0.30, 0.42)
OPTS = {"grain_metal": 0.05, "grain_z_min": 3.0, "albedo_sigma": 0.08}


def _patch(finish: str, *, light: float = 255.0, noise: float = 1.5, grain: bool | None = None,
           seed: int = 0, size: int = 40):
    """A flat patch of a catalogue finish under white light, with the belt's reading."""
    rng = np.random.default_rng(seed)
    m = MATERIALS[finish]
    rgb = np.array(m.rgba[:3]) * light
    if grain is None:
        grain = m.material == "metal"
    img = np.tile(rgb, (size, size, 1))
    if grain:  # sub-pixel speckle: 35 % of texels at 0.72, averaged ~4 texels a pixel
        texels = np.where(rng.random((size, size, 4)) < 0.35, 0.72, 1.0).mean(axis=2)
        img = img * texels[..., None]
    img = img + rng.normal(0, noise, img.shape)
    patch = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    belt_seen = np.array(BELT) * light
    return patch, np.ones((size, size), bool), belt_seen


@pytest.mark.parametrize("finish", list(MATERIALS))
def test_every_finish_classified_under_front_light(finish):
    patch, mask, belt = _patch(finish)
    f = material_features(patch, mask, belt, belt_rgb=BELT)
    label, conf = classify_material(f, backlit=False, **OPTS)
    assert label == MATERIALS[finish].material and conf > 0.5


@pytest.mark.parametrize("finish", ["steel", "aluminium"])
def test_grain_not_colour_tells_grey_metal_from_grey_plastic(finish):
    """The same grey with grain is metal; without grain and a plastic's albedo, plastic."""
    metal, mask, belt = _patch(finish)
    smooth, _, _ = _patch("plastic_grey" if finish == "steel" else "plastic_white")
    fm = material_features(metal, mask, belt, belt_rgb=BELT)
    fs = material_features(smooth, mask, belt, belt_rgb=BELT)
    assert fm.grain > 0.05 and fm.grain_z > 3
    assert fs.grain < 0.02
    assert classify_material(fm, backlit=False, **OPTS)[0] == "metal"
    assert classify_material(fs, backlit=False, **OPTS)[0] == "plastic"


def test_sensor_noise_is_not_taken_for_grain():
    """Strong per-channel noise (dim light, gain 4) on smooth plastic shows no grain."""
    patch, mask, belt = _patch("plastic_white", light=60.0, noise=6.0, size=60)
    f = material_features(patch, mask, belt, belt_rgb=BELT)
    assert f.grain_z < 3


def test_brass_is_metal_and_yellow_plastic_is_not():
    for finish, want in (("brass", "metal"), ("plastic_yellow", "plastic")):
        patch, mask, belt = _patch(finish, light=200.0)
        f = material_features(patch, mask, belt, belt_rgb=BELT)
        assert classify_material(f, backlit=False, **OPTS)[0] == want


def test_backlit_is_unknown():
    patch, mask, belt = _patch("steel")
    f = material_features(patch, mask, belt, belt_rgb=BELT)
    assert classify_material(f, backlit=True, **OPTS) == ("unknown", 0.0)


def test_albedo_is_white_balanced_by_the_belt():
    """A warm light scales channels differently; the belt reading undoes it."""
    patch, mask, _ = _patch("plastic_white", noise=0.0)
    gain = np.array([1.1, 0.85, 0.6])
    warm = np.clip(patch * gain, 0, 255).astype(np.uint8)
    f = material_features(warm, mask, np.array(BELT) * 255 * gain, belt_rgb=BELT)
    np.testing.assert_allclose(f.albedo, MATERIALS["plastic_white"].rgba[:3], atol=0.02)


def test_bad_input_names_the_argument():
    patch, mask, belt = _patch("steel")
    with pytest.raises(VisionError, match="patch"):
        material_features(patch[..., 0], mask, belt, belt_rgb=BELT)
    with pytest.raises(VisionError, match="mask"):
        material_features(patch, mask[:5], belt, belt_rgb=BELT)
    with pytest.raises(VisionError, match="mask"):
        material_features(patch, np.zeros_like(mask), belt, belt_rgb=BELT)
