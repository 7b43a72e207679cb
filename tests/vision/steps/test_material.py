"""Material step: grain separates metal from plastic whatever the colour and noise."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cell.catalogue import MATERIALS
from cell.errors import VisionError
from cell.vision.settings import VisionSettings
from cell.vision.steps.material import (
    MaterialFeatures,
    PartPixels,
    classify_material,
    material_features,
    noise_sigma,
    part_materials,
)

BELT = (0.22, 0.30, 0.42)
OPTS = {"grain_metal": 0.05, "grain_z_min": 3.0, "albedo_sigma": 0.08}
SETTINGS = VisionSettings(belt_rgb=BELT, **OPTS)


def _surface(finish: str, shape: tuple[int, int], rng, *, light: float = 255.0,
             noise: float = 1.5, grain: bool | None = None) -> np.ndarray:
    """A flat surface of a catalogue finish under white light (float RGB): a metal's grain
    is sub-pixel speckle, 35 % of texels at 0.72, about 4 texels averaged a pixel."""
    m = MATERIALS[finish]
    img = np.tile(np.array(m.rgba[:3]) * light, (*shape, 1))
    if m.material == "metal" if grain is None else grain:
        img = img * np.where(rng.random((*shape, 4)) < 0.35, 0.72, 1.0).mean(axis=2)[..., None]
    return img + rng.normal(0, noise, img.shape)


def _patch(finish: str, *, light: float = 255.0, noise: float = 1.5, grain: bool | None = None,
           seed: int = 0, size: int = 40):
    """A patch of a finish, its full mask and the belt's reading under the same light."""
    rng = np.random.default_rng(seed)
    img = _surface(finish, (size, size), rng, light=light, noise=noise, grain=grain)
    patch = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    return patch, np.ones((size, size), bool), np.array(BELT) * light


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


def test_flat_patch_features_are_worked_out():
    """A uniform patch: mean exact, no residual (grain 0), nothing clipped, and the grain
    measured on the flat, lit pixels (all of them, here)."""
    patch = np.full((20, 30, 3), (90, 120, 60), np.uint8)
    f = material_features(patch, np.ones((20, 30), bool), np.array([45.0, 60.0, 90.0]),
                          belt_rgb=BELT)
    np.testing.assert_allclose(f.mean_rgb, [90, 120, 60], rtol=1e-12)
    np.testing.assert_allclose(f.albedo, [0.44, 0.6, 0.28], rtol=1e-12)
    assert f.grain == 0.0 and f.clipped == 0.0
    assert f.pixels == f.grain_pixels == 600


def test_bad_input_names_the_argument():
    patch, mask, belt = _patch("steel")
    with pytest.raises(VisionError, match="patch"):
        material_features(patch[..., 0], mask, belt, belt_rgb=BELT)
    with pytest.raises(VisionError, match="mask"):
        material_features(patch, mask[:5], belt, belt_rgb=BELT)
    with pytest.raises(VisionError, match="mask"):
        material_features(patch, np.zeros_like(mask), belt, belt_rgb=BELT)


def _features(grain, grain_z, *, albedo=(0.9, 0.9, 0.88), even=0.25, pixels=400, visibility=7.0):
    return MaterialFeatures(mean_rgb=np.zeros(3), albedo=np.array(albedo), grain=grain,
                            grain_z=grain_z, clipped=0.0, pixels=pixels,
                            grain_visibility=visibility, grain_pixels=int(even * pixels))


def test_grain_evidence_does_not_jump_at_the_threshold():
    """Clear grain just short of grain_z_min (one interior pixel more or less) still counts
    nearly fully: a grainy part with a white plastic's albedo is metal either side."""
    z_min = OPTS["grain_z_min"]
    below = classify_material(_features(0.08, z_min - 0.02), backlit=False, **OPTS)
    above = classify_material(_features(0.08, z_min + 0.02), backlit=False, **OPTS)
    assert below[0] == above[0] == "metal"
    assert abs(below[1] - above[1]) < 0.05


def test_weak_grain_counts_only_with_strong_evidence_on_an_evenly_lit_surface():
    """A metal under a specular spot: its grain reads below grain_metal; with strong evidence
    on an evenly lit surface it is metal, not where directional light shades a thread."""
    grain, z_min = 0.75 * OPTS["grain_metal"], OPTS["grain_z_min"]
    weak = _features(grain, z_min + 1.0)
    assert classify_material(weak, backlit=False, **OPTS)[0] == "metal"
    shaded = _features(grain, z_min + 1.0, even=0.15)
    assert classify_material(shaded, backlit=False, **OPTS)[0] == "plastic"
    raking = _features(grain, z_min + 1.0, even=0.19)  # a flat nut under raking light
    assert classify_material(raking, backlit=False, **OPTS)[0] == "metal"
    faint = _features(grain, z_min)  # weak grain needs more than grain_z_min
    assert classify_material(faint, backlit=False, **OPTS)[0] == "plastic"


def test_albedo_alone_is_never_sure_and_clear_grain_wins():
    """A white plastic's albedo without grain evidence: plastic, held at 0.95; clear grain
    on the same albedo multiplies the odds by 50: metal at 50 * 0.05 / 0.95 odds."""
    label, conf = classify_material(_features(0.03, 0.0), backlit=False, **OPTS)
    assert label == "plastic" and conf == pytest.approx(0.95, abs=1e-9)
    label, conf = classify_material(_features(0.1, 10.0), backlit=False, **OPTS)
    odds = 50 * 0.05 / 0.95
    assert label == "metal" and conf == pytest.approx(odds / (1 + odds), rel=1e-9)


def test_grain_alone_does_not_make_a_colour_no_metal_has_metal():
    """Under raking light a green plastic bolt's shading passed for grain: clear grain
    multiplied a prior held at 0.05 to metal at 0.72. No metal finish is green: its prior is
    held from 0.01, and the same grain leaves it plastic; on a grey part it still says metal,
    and a brighter or darker reading of the same green changes nothing."""
    green = np.array(MATERIALS["plastic_green"].rgba[:3])
    for scale in (0.8, 1.0, 1.3):
        label, _ = classify_material(_features(0.1, 10.0, albedo=scale * green), backlit=False, **OPTS)
        assert label == "plastic", scale
    grey = classify_material(_features(0.1, 10.0, albedo=(0.45, 0.45, 0.46)), backlit=False, **OPTS)
    assert grey[0] == "metal"
    brass = np.array(MATERIALS["brass"].rgba[:3]) * 0.9  # a metal's own hue keeps the 0.05 floor
    assert classify_material(_features(0.1, 10.0, albedo=brass), backlit=False, **OPTS)[0] == "metal"


def test_no_grain_where_it_would_show_says_plastic_against_a_metals_albedo():
    """Under raking light a grey plastic nut reads 1.3-1.5x brighter: its albedo is
    steel's. A metal's grain would stand 4.4 standard errors above the noise there, and it
    shows none: plastic. Where the grain could not show (visibility 3), the albedo decides."""
    steel_like = (0.62, 0.61, 0.63)
    no_grain = _features(0.0, -0.5, albedo=steel_like, visibility=4.4)
    assert classify_material(no_grain, backlit=False, **OPTS)[0] == "plastic"
    unseen = _features(0.0, -0.5, albedo=steel_like, visibility=3.0)
    assert classify_material(unseen, backlit=False, **OPTS)[0] == "metal"


# noise_sigma


def test_noise_sigma_worked_example():
    """Differences of green pixels two apart on rows 4 and 20: 6, -6, 6, -6 and four 0.
    Upper median 0 (element 4 of 8 in order); deviations four 0 and four 6: MAD 6."""
    img = np.zeros((24, 9, 3), np.uint8)
    img[4, ::2, 1] = [0, 6, 0, 6, 0]
    img[5, :, 1] = 200  # rows other than 4 + 16 k are not read
    assert noise_sigma(img) == pytest.approx(1.4826 * 6 / math.sqrt(2), rel=1e-12)
    assert noise_sigma(img[:4]) == 0.0  # no row 4: no estimate


def test_noise_sigma_reads_gaussian_noise():
    rng = np.random.default_rng(3)
    for sigma in (2.0, 5.0):
        img = np.clip(np.rint(120 + rng.normal(0, sigma, (480, 640, 3))), 0, 255).astype(np.uint8)
        assert noise_sigma(img) == pytest.approx(sigma, rel=0.1)


# part_materials: whole frames


def _frame(finishes: list[str], *, seed: int = 0, light: float = 255.0, belt=BELT):
    """A frame of belt with a disc of each finish in a row (radius 14 px, 40 px apart):
    the image, its foreground and the parts."""
    rng = np.random.default_rng(seed)
    h, w = 64, 40 * len(finishes) + 24
    img = np.array(belt) * light + rng.normal(0, 1.5, (h, w, 3))
    fg = np.zeros((h, w), np.uint8)
    parts = []
    for k, finish in enumerate(finishes):
        disc = np.zeros((30, 30), np.uint8)
        cv2.circle(disc, (15, 15), 14, 255, -1)
        x0, y0 = 12 + 40 * k, 17
        on = disc != 0
        img[y0 : y0 + 30, x0 : x0 + 30][on] = _surface(finish, (30, 30), rng, light=light)[on]
        fg[y0 : y0 + 30, x0 : x0 + 30][on] = 255
        parts.append(PartPixels(x0, y0, disc))
    return np.clip(np.rint(img), 0, 255).astype(np.uint8), fg, parts


def test_part_materials_reads_metal_and_plastic_on_the_belt():
    finishes = ["steel", "plastic_white", "brass", "plastic_yellow", "aluminium", "plastic_grey",
                "plastic_black"]
    img, fg, parts = _frame(finishes)
    got = part_materials(img, fg, parts, settings=SETTINGS, backlit=False)
    assert [g[0] for g in got] == [MATERIALS[f].material for f in finishes]
    assert all(0.5 <= c <= 1.0 and math.isfinite(c) for _, c in got)


def test_part_materials_agree_with_the_features_of_each_interior():
    """A part's label is classify_material of the features of its mask eroded 5x5, with the
    belt's mean colour around it (the frame's noise_sigma as floor)."""
    img, fg, parts = _frame(["steel", "plastic_grey"], seed=4)
    got = part_materials(img, fg, parts, settings=SETTINGS, backlit=False)
    for part, (label, conf) in zip(parts, got, strict=True):
        inner = cv2.erode(part.mask, np.ones((5, 5), np.uint8)) != 0
        h, w = part.mask.shape
        box = np.s_[part.y0 : part.y0 + h, part.x0 : part.x0 + w]
        win = np.s_[part.y0 - 6 : part.y0 + h + 6, part.x0 - 6 : part.x0 + w + 6]
        belt = img[win][fg[win] != 255].mean(axis=0)
        f = material_features(img[box], inner, belt, belt_rgb=BELT, noise_sigma=noise_sigma(img))
        want = classify_material(f, backlit=False, **OPTS)
        assert label == want[0] and conf == pytest.approx(want[1], abs=1e-9)


def test_part_materials_unknown_where_no_cue_exists():
    img, fg, parts = _frame(["steel", "plastic_red"])
    assert part_materials(img, fg, parts, settings=SETTINGS, backlit=True) == [("unknown", 0.0)] * 2
    assert part_materials(img, fg, [], settings=SETTINGS, backlit=False) == []
    tiny = np.zeros((6, 6), np.uint8)
    tiny[1:5, 1:5] = 255  # 16 px: 3x3 erosion leaves 4
    empty = np.zeros((5, 5), np.uint8)
    got = part_materials(img, fg, [PartPixels(2, 2, tiny), PartPixels(0, 0, empty), parts[0]],
                         settings=SETTINGS, backlit=False)
    assert got[:2] == [("unknown", 0.0)] * 2 and got[2][0] == "metal"
    table, fg_t, parts_t = _frame(["steel"], belt=(0.95, 0.95, 0.95))  # a light table
    assert part_materials(table, fg_t, parts_t, settings=SETTINGS, backlit=False) == [("unknown", 0.0)]


def test_part_without_belt_around_takes_the_frames_free_pixels():
    """A part whose box and 6 px around it are all foreground: the belt's colour is the
    median of the free pixels of the frame; a frame without any is unknown."""
    img, fg, parts = _frame(["steel", "plastic_white"])
    walled = fg.copy()
    p = parts[1]
    walled[p.y0 - 6 : p.y0 + 36, p.x0 - 6 : p.x0 + 36] = 255
    got = part_materials(img, walled, parts, settings=SETTINGS, backlit=False)
    assert [g[0] for g in got] == ["metal", "plastic"]
    full = np.full_like(fg, 255)
    assert part_materials(img, full, parts, settings=SETTINGS, backlit=False) == [("unknown", 0.0)] * 2


def test_noise_alone_does_not_fake_grain_in_a_frame():
    """Dim light at high gain: smooth white plastic stays plastic."""
    img, fg, parts = _frame(["plastic_white"], light=70.0, seed=2)
    noisy = np.clip(img + np.random.default_rng(5).normal(0, 5, img.shape), 0, 255).astype(np.uint8)
    assert part_materials(noisy, fg, parts, settings=SETTINGS, backlit=False)[0][0] == "plastic"


def _clipped_noise(image: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    """``image`` plus Gaussian noise of ``sigma`` grey levels, rounded and saturated to
    0..255 as the sensor does."""
    rng = np.random.default_rng(seed)
    return np.clip(np.rint(image + sigma * rng.standard_normal(image.shape)), 0, 255).astype(np.uint8)


_BRIGHT_AND_DARK = ["plastic_yellow", "brass", "plastic_white", "aluminium", "steel", "plastic_grey"]


@pytest.mark.parametrize("seed", range(4))
def test_noise_the_sensor_clips_does_not_turn_plastic_into_metal(seed):
    """Noise of sigma 75 saturates at 0 and 255: yellow plastic's blue and the belt's red
    read brighter, white plastic's channels darker, so yellow looked like brass and white like
    aluminium (metal at 0.95). Their means are taken back before the albedo is read."""
    img, fg, parts = _frame(_BRIGHT_AND_DARK, seed=seed)
    got = part_materials(_clipped_noise(img, 75, 100 + seed), fg, parts, settings=SETTINGS,
                         backlit=False)
    assert [g.material for g in got] == [MATERIALS[f].material for f in _BRIGHT_AND_DARK]


def test_a_label_that_hangs_on_the_noise_estimate_is_unknown():
    """At sigma 90 the frame's noise estimate reads low (the sensor clips much of the noise)
    and the colours taken back with it still lean to a metal's: a part whose label changes
    when the noise is read 1.25x higher is unknown. None is labelled wrong."""
    got = []
    for seed in range(4):
        img, fg, parts = _frame(_BRIGHT_AND_DARK, seed=seed)
        got += [(g.material, MATERIALS[f].material) for g, f in zip(
            part_materials(_clipped_noise(img, 90, 100 + seed), fg, parts, settings=SETTINGS,
                           backlit=False), _BRIGHT_AND_DARK, strict=True)]
    assert all(said in ("unknown", truth) for said, truth in got)
    assert ("unknown", "plastic") in got and sum(said == truth for said, truth in got) >= 18


def _salt_and_pepper(image: np.ndarray, share: float, seed: int) -> np.ndarray:
    """``image`` with ``share`` of its pixels black or white, as the sensor's salt and pepper."""
    rng = np.random.default_rng(seed)
    out = image.copy()
    hit = rng.random(out.shape[:2]) < share
    out[hit] = (rng.integers(0, 2, int(hit.sum())) * 255).astype(np.uint8)[:, None]
    return out


_EIGHT = [*_BRIGHT_AND_DARK, "plastic_red", "plastic_black"]


@pytest.mark.parametrize("seed", range(3))
def test_heavy_salt_and_pepper_is_read_through_a_median_without_grain(seed):
    """20 % of the pixels black or white pull every mean to grey and fake grain: read as
    it is, yellow plastic is metal. Over 7.5 % the frame's 3x3 median is read, by its
    albedo alone."""
    img, fg, parts = _frame(_EIGHT, seed=seed)
    noisy = _salt_and_pepper(img, 0.2, 50 + seed)
    got = part_materials(noisy, fg, parts, settings=SETTINGS, backlit=False, impulses=0.2)
    assert [g.material for g in got] == [MATERIALS[f].material for f in _EIGHT]
    assert part_materials(noisy, fg, parts, settings=SETTINGS, backlit=False)[0].material == "metal"


def test_light_salt_and_pepper_keeps_the_grain():
    """Up to 7.5 % impulse noise the robust scales hold: the frame is read as it is, grain
    and all (a median would take a metal's grain out with the specks)."""
    img, fg, parts = _frame(_EIGHT, seed=1)
    noisy = _salt_and_pepper(img, 0.05, 7)
    got = part_materials(noisy, fg, parts, settings=SETTINGS, backlit=False, impulses=0.05)
    assert got == part_materials(noisy, fg, parts, settings=SETTINGS, backlit=False)
    assert [g.material for g in got] == [MATERIALS[f].material for f in _EIGHT]
    assert got[1].confidence > 0.99  # brass: its grain counts, beyond the albedo's 0.95
    grainless = part_materials(noisy, fg, parts, settings=SETTINGS, backlit=False, impulses=0.08)
    assert grainless[1].confidence <= 0.95


@pytest.mark.parametrize("impulses", [-0.1, 1.5, float("nan"), "0.1"])
def test_part_materials_refuses_a_bad_impulse_share(impulses):
    img, fg, parts = _frame(["steel"])
    with pytest.raises(VisionError, match="impulses"):
        part_materials(img, fg, parts, settings=SETTINGS, backlit=False, impulses=impulses)


def test_a_coarsely_quantised_frame_is_read_without_grain_and_half_a_step_up():
    """A 3-bit sensor (steps of 32, truncating): no grain survives it, yet its absence
    counted against metal (steel read plastic), and every mean reads half a step dark.
    From steps of 8 the grain does not count and the means are raised by half a step."""
    img, fg, parts = _frame(_EIGHT, seed=2)
    coarse = img & np.uint8(0xE0)
    got = part_materials(coarse, fg, parts, settings=SETTINGS, backlit=False)
    assert [g.material for g in got] == [MATERIALS[f].material for f in _EIGHT]


def test_four_grey_levels_a_channel_have_no_colour_to_read():
    img, fg, parts = _frame(_EIGHT, seed=2)
    got = part_materials(img & np.uint8(0xC0), fg, parts, settings=SETTINGS, backlit=False)
    assert got == [("unknown", 0.0)] * len(_EIGHT)


def test_a_noise_estimate_beyond_255_is_no_error(monkeypatch):
    """A crafted frame's noise estimate can read over 200 grey levels (1.4826 x a MAD of up
    to 255, over sqrt 2), and the second reading takes 1.25x that: the clipping is undone
    with at most 255, not refused as an argument out of range."""
    import cell.vision.steps.material as material

    img, fg, parts = _frame(["steel", "plastic_yellow"])
    monkeypatch.setattr(material, "noise_sigma", lambda image: 240.0)
    got = part_materials(img, fg, parts, settings=SETTINGS, backlit=False)
    assert len(got) == 2 and all(g.material in ("metal", "plastic", "unknown") for g in got)


def test_part_materials_bad_input_names_the_argument():
    img, fg, parts = _frame(["steel"])
    with pytest.raises(VisionError, match="image"):
        part_materials(img[..., 0], fg, parts, settings=SETTINGS, backlit=False)
    with pytest.raises(VisionError, match="foreground"):
        part_materials(img, fg[:5], parts, settings=SETTINGS, backlit=False)
    with pytest.raises(VisionError, match="settings"):
        part_materials(img, fg, parts, settings=None, backlit=False)
    with pytest.raises(VisionError, match="parts"):
        part_materials(img, fg, [PartPixels(img.shape[1] - 3, 0, parts[0].mask)],
                       settings=SETTINGS, backlit=False)
    with pytest.raises(VisionError, match="parts"):
        part_materials(img, fg, [(0, 0, parts[0].mask)], settings=SETTINGS, backlit=False)


@pytest.mark.parametrize("change, culprit", [
    ({"patch": lambda p: p.astype(np.float64) / 255}, "argument 'patch' must be uint8"),  # 0..1
    ({"patch": lambda p: p.astype(np.int64) * 1000}, "argument 'patch' must be uint8"),
    ({"mask": lambda m: m.astype(np.float64) * 0.5}, "argument 'mask' must be bool or uint8"),
    ({"belt": lambda b: np.array([np.nan, 80, 110])}, "argument 'belt_rgb_seen'"),
    ({"belt": lambda b: "abc"}, "argument 'belt_rgb_seen'"),
    ({"belt": lambda b: np.array([60.0, 80])}, "argument 'belt_rgb_seen'"),
    ({"belt_rgb": (0, 0, 0)}, "argument 'belt_rgb' must be above 0"),
    ({"belt_rgb": (1, 2)}, "argument 'belt_rgb'"),
    ({"belt_rgb": (0.3, np.nan, 0.4)}, "argument 'belt_rgb'"),
    ({"noise_sigma": np.nan}, "argument 'noise_sigma'"),
    ({"noise_sigma": -1.0}, "argument 'noise_sigma'"),
    ({"noise_sigma": "1"}, "argument 'noise_sigma'"),
])
def test_material_features_refuses_bad_values(change, culprit):
    patch, mask, belt = _patch("steel")
    patch = change.get("patch", lambda p: p)(patch)
    mask = change.get("mask", lambda m: m)(mask)
    belt = change.get("belt", lambda b: b)(belt)
    with pytest.raises(VisionError, match=culprit):
        material_features(patch, mask, belt, belt_rgb=change.get("belt_rgb", BELT),
                          noise_sigma=change.get("noise_sigma", 0.0))


def test_material_features_takes_a_uint8_mask():
    patch, mask, belt = _patch("steel")
    a = material_features(patch, mask, belt, belt_rgb=BELT)
    b = material_features(patch, mask.astype(np.uint8) * 255, belt, belt_rgb=BELT)
    assert (a.grain, a.grain_z, a.pixels) == (b.grain, b.grain_z, b.pixels)
    np.testing.assert_array_equal(a.albedo, b.albedo)


@pytest.mark.parametrize("change, culprit", [
    ({"grain_metal": np.nan}, "argument 'grain_metal'"),  # was 'metal'
    ({"albedo_sigma": 0}, "argument 'albedo_sigma'"),  # was a NaN confidence
    ({"grain_z_min": "3"}, "argument 'grain_z_min'"),
    ({"backlit": "no"}, "argument 'backlit'"),
    ({"features": "f"}, "argument 'features' must be MaterialFeatures"),
    ({"features": _features(np.nan, 5.0)}, "argument 'features' must hold finite"),
])
def test_classify_material_refuses_bad_values(change, culprit):
    call = {"features": _features(0.1, 10.0), "backlit": False, **OPTS, **change}
    with pytest.raises(VisionError, match=culprit):
        classify_material(call.pop("features"), **call)


def test_grain_on_a_dark_part_does_not_count():
    """On a part whose albedo averages under 0.25 the noise swamps a metal's grain: what
    reads as grain there changes nothing (a black plastic part stays plastic, as sure)."""
    dark = (0.08, 0.08, 0.08)
    grainy = classify_material(_features(0.08, 10.0, albedo=dark), backlit=False, **OPTS)
    smooth = classify_material(_features(0.0, 0.0, albedo=dark), backlit=False, **OPTS)
    assert grainy == smooth and grainy[0] == "plastic"


def test_a_belt_bright_in_one_channel_is_no_light_table():
    """An orange belt (230, 150, 61) has a channel above backlight_level, not all three:
    the parts on it are measured, not left unknown as silhouettes on a light table."""
    orange = (0.9, 0.59, 0.24)
    settings = VisionSettings(belt_rgb=orange, **OPTS)
    assert max(orange) * 255 >= settings.backlight_level > min(orange) * 255
    img, fg, parts = _frame(["steel", "plastic_grey"], belt=orange)
    got = part_materials(img, fg, parts, settings=settings, backlit=False)
    assert [g[0] for g in got] == ["metal", "plastic"]
