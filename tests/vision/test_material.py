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


# The compiled statistics reproduce the OpenCV pipeline they replace, bit for bit.

def _opencv_statistics(patch: np.ndarray, mask: np.ndarray) -> list[float]:
    """The statistics row of patch_statistics, computed with OpenCV and numpy."""
    import cv2

    pad = cv2.copyMakeBorder(patch, 2, 2, 2, 2, cv2.BORDER_REFLECT_101)
    at = np.flatnonzero(np.pad(mask, 2))
    n = len(at)
    pix = pad.reshape(-1, 3)[at]
    means = pix.sum(axis=0, dtype=np.float64) * (1.0 / n)
    grey = cv2.blur(cv2.cvtColor(pad, cv2.COLOR_RGB2GRAY), (3, 3))
    gx, gy = (g.reshape(-1)[at].astype(np.int32) for g in cv2.spatialGradient(grey))
    slope = gx * gx + gy * gy
    lit = grey.reshape(-1)[at]
    flat = (slope <= np.partition(slope, n // 2)[n // 2]) & (lit >= np.partition(lit, n // 2)[n // 2])
    local = cv2.blur(pad, (3, 3)).reshape(-1, 3)[at[flat]]
    resid = cv2.subtract(pix[flat], local, dtype=cv2.CV_32F).reshape(-1, 1, 3)
    norm = float(np.sqrt(means @ means))
    unit = (means / norm if norm > 1e-6 else np.full(3, 1 / np.sqrt(3))).astype(np.float32)
    par = cv2.transform(resid, unit[None]).reshape(-1)
    orth2 = cv2.transform(resid * resid, np.ones((1, 3), np.float32)).reshape(-1) - par * par
    m = len(par)
    med = np.partition(par, m // 2)[m // 2]
    mad = np.partition(np.abs(par - med), m // 2)[m // 2]
    unclipped = int(np.count_nonzero((pix <= 253).all(axis=1)))
    return [n, m, *means, norm, 1.4826 * float(mad), float(np.partition(orth2, m // 2)[m // 2]),
            unclipped]


@pytest.mark.parametrize("seed", range(40))
def test_patch_statistics_equal_opencv_pipeline(seed):
    from cell.vision._material_kernel import patch_statistics

    rng = np.random.default_rng(seed)
    h, w = rng.integers(1, 40, 2) if seed % 4 else rng.integers(8, 12, 2)
    base = rng.integers(0, 256, 3)
    noise = rng.integers(0, 40 if seed % 3 else 4)  # few levels: many ties in the medians
    patch = np.clip(base + rng.integers(-noise, noise + 1, (h, w, 3)), 0, 255).astype(np.uint8)
    mask = rng.random((h, w)) < rng.uniform(0.3, 1.0)
    if mask.sum() < 8:
        mask[:] = True
    if mask.sum() < 8:
        pytest.skip("patch under 8 pixels")
    got = patch_statistics(patch, mask.view(np.uint8))
    # compiled kernel against OpenCV/numpy: equal within 1e-9 relative (the last bits
    # depend on the CPU: fused multiply-add, vector width)
    np.testing.assert_allclose(got, _opencv_statistics(patch, mask), rtol=1e-9, atol=1e-9)


def test_erosion_and_box_equal_cv2():
    import cv2

    from cell.vision._part_material import _PAD, _erode

    rng = np.random.default_rng(1)
    for _ in range(500):
        h, w = rng.integers(1, 30, 2)
        roi = ((rng.random((h, w)) < rng.uniform(0.2, 1.3)) * 255).astype(np.uint8)
        padded = np.full((h, w + 2 * _PAD), 255, np.uint8)
        padded[:, _PAD:-_PAD] = roi
        for r in (1, 2):
            out = np.empty_like(padded)
            n, ya, yb, xa, xb = _erode(padded, r, np.empty_like(padded), out)
            want = cv2.erode(roi, np.ones((2 * r + 1, 2 * r + 1), np.uint8))
            assert np.array_equal(out[:, _PAD:-_PAD] != 0, want != 0)
            assert n == np.count_nonzero(want)
            if n:
                assert (xa - _PAD, ya, xb - xa, yb - ya) == cv2.boundingRect(want)


@pytest.mark.parametrize("dtype", [np.int32, np.float32])
def test_select_equals_partition(dtype):
    from cell.vision._material_kernel import _select

    rng = np.random.default_rng(2)
    for _ in range(300):
        v = (rng.integers(-5, 6, rng.integers(1, 300)) * rng.choice([1, 0.37])).astype(dtype)
        k = int(rng.integers(0, len(v)))
        assert _select(v.copy(), k) == np.partition(v, k)[k]


def test_noise_estimate_equals_frame_view():
    from cell.vision._part_material import noise_sigma
    from cell.vision._segment import FrameView

    rng = np.random.default_rng(3)
    for h, w in [(16, 16), (17, 33), (120, 161)]:
        img = np.clip(100 + rng.normal(0, 4, (h, w, 3)), 0, 255).astype(np.uint8)
        view = FrameView(img, None, None, None, 0, 0, False, None, None, 0, 0)
        assert noise_sigma(img) == pytest.approx(view.noise_sigma(), rel=1e-9, abs=1e-12)


def test_metal_prior_equals_numpy_softmax():
    from cell.vision.material import _FINISH_ALBEDO, _FINISH_METAL, _albedo_metal_probability

    rng = np.random.default_rng(4)
    albedo = rng.random((50, 3))
    d2 = ((_FINISH_ALBEDO - albedo[:, None]) ** 2).sum(axis=2) / 0.08**2
    w = np.exp(-(d2 - d2.min(axis=1, keepdims=True)) / 2)
    want = w[:, _FINISH_METAL].sum(axis=1) / w.sum(axis=1)
    np.testing.assert_allclose(_albedo_metal_probability(albedo, 0.08), want, rtol=1e-12, atol=1e-15)


def _features(grain, grain_z, *, albedo=(0.9, 0.9, 0.88), even=0.25, pixels=400):
    from cell.vision.material import MaterialFeatures

    return MaterialFeatures(mean_rgb=np.zeros(3), albedo=np.array(albedo), grain=grain,
                            grain_z=grain_z, clipped=0.0, pixels=pixels, grain_visibility=7.0,
                            grain_pixels=int(even * pixels))


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
    faint = _features(grain, z_min)  # weak grain needs more than grain_z_min
    assert classify_material(faint, backlit=False, **OPTS)[0] == "plastic"


def test_frame_statistics_equal_per_part_opencv():
    """Every part of a frame in one pass: the erosion (cv2.erode, 5x5 or 3x3), the belt's
    mean colour (free pixels around the ROI) and the interior's statistics equal those
    computed part by part with OpenCV and patch_statistics."""
    import cv2

    from cell.vision._material_kernel import patch_statistics
    from cell.vision._part_material import MEASURED, NO_BELT, frame_statistics

    rng = np.random.default_rng(5)
    for _ in range(60):
        img = rng.integers(0, 256, (60, 80, 3), dtype=np.uint8)
        img[rng.random((60, 80)) < 0.5] //= 4
        fg = np.where(rng.random((60, 80)) < rng.uniform(0.0, 1.0), 255, 0).astype(np.uint8)
        boxes, masks, want = [], [], []
        for _ in range(rng.integers(1, 4)):
            h, w = rng.integers(3, 40, 2)
            x0, y0 = rng.integers(0, 80 - w), rng.integers(0, 60 - h)
            m = np.zeros((h, w), np.uint8)  # a filled ellipse, anywhere in the ROI
            cv2.ellipse(m, (int(rng.integers(0, w)), int(rng.integers(0, h))),
                        (int(rng.integers(1, 25)), int(rng.integers(1, 25))),
                        float(rng.uniform(0, 180)), 0, 360, 255, -1)
            boxes.append((x0, y0, h, w))
            masks.append(m.reshape(-1))
            inner = cv2.erode(m, np.ones((5, 5), np.uint8))
            if np.count_nonzero(inner) < 150:
                inner = cv2.erode(m, np.ones((3, 3), np.uint8))
            xa, ya, xb, yb = max(x0 - 6, 0), max(y0 - 6, 0), min(x0 + w + 6, 80), min(y0 + h + 6, 60)
            free = fg[ya:yb, xa:xb] != 255
            n = int(np.count_nonzero(free))
            sums = img[ya:yb, xa:xb][free].sum(axis=0, dtype=np.int64)
            belt = [n, *(sums * (1.0 / n) if n >= 30 else np.zeros(3))]
            if np.count_nonzero(inner) < 8 or (n >= 30 and min(belt[1:]) >= 200):
                want.append((0, None, belt if np.count_nonzero(inner) >= 8 else [0, 0, 0, 0]))
                continue
            bx, by, bw, bh = cv2.boundingRect(inner)
            py0, py1, px0, px1 = max(by - 2, 0), min(by + bh + 2, h), max(bx - 2, 0), min(bx + bw + 2, w)
            patch = np.ascontiguousarray(img[y0 + py0 : y0 + py1, x0 + px0 : x0 + px1])
            row = patch_statistics(patch, np.ascontiguousarray(inner[py0:py1, px0:px1]))
            want.append((MEASURED if n >= 30 else NO_BELT, row, belt))
        stats, belts, state = frame_statistics(img, fg, np.array(boxes, np.int64),
                                               np.concatenate(masks), 200.0)
        for j, (s, row, belt) in enumerate(want):
            assert state[j] == s
            np.testing.assert_allclose(belts[j], [float(v) for v in belt], rtol=1e-9)
            if row is not None:
                np.testing.assert_allclose(stats[j], row, rtol=1e-9, atol=1e-9)
