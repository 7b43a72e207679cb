"""Metal or plastic from a part's pixels: grain texture first, white-balanced albedo second.

Colour alone cannot tell grey or white plastic from steel or aluminium, nor yellow
plastic from brass, so the classifier looks at two cues that do not depend on hue:

* **Grain** (texture). A machined metal surface has a fine grain that modulates the
  brightness of its own colour; sensor noise is independent in each channel. Projecting
  each pixel's deviation from the part's mean colour onto that colour's direction gives
  grain + noise; the two directions orthogonal to it give noise only. Their difference
  estimates the grain variance free of the sensor noise, with a standard error, so a
  dim, noisy frame does not fake grain (after the colour-space noise model of
  Healey & Kondepudy, *Radiometric CCD camera calibration and noise estimation*, 1994).
* **Albedo**. The part's mean colour divided by the belt's colour next to it, times the
  belt's known reflectance (a white balance against a reference surface of known
  colour), is compared with the catalogue's finishes; metals also read brighter under
  specular light. This decides when the grain is inconclusive.

Under a back-light the part is a silhouette: neither cue exists, and the material is
``"unknown"`` rather than a guess.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import accumulate

import cv2
import numpy as np

from cell.catalogue import MATERIALS
from cell.errors import VisionError

__all__ = ["SUPPORT", "MaterialFeatures", "classify_material", "classify_materials",
           "material_features", "mosaic_features"]

_HIGHPASS_GAIN = math.sqrt((8 / 9) ** 2 + 8 / 81)  # white noise through I - box3x3(I)
_GRAIN_MEAN = 0.9  # the metal grain's mean brightness factor (texture mean over texels)
SUPPORT = 2  # px: how far the features' filters (3x3 mean, then 3x3 Sobel) read around a pixel


@dataclass(frozen=True)
class MaterialFeatures:
    """What the material classifier looks at, for one part.

    ``mean_rgb`` the mean colour (grey levels); ``albedo`` the white-balanced reflectance
    per channel (0..1, may exceed 1 under specular light); ``grain`` the grain amplitude
    relative to the mean brightness (0 for a smooth surface); ``grain_z`` the grain
    variance in units of its standard error (evidence that grain exists); ``clipped``
    the fraction of saturated pixels; ``pixels`` how many pixels were used;
    ``grain_visibility`` how many standard errors a metal's grain (5 % of the brightness)
    would stand above the noise here: where it is small (dim, noisy, tiny), the absence of
    grain says nothing.
    """

    mean_rgb: np.ndarray
    albedo: np.ndarray
    grain: float
    grain_z: float
    clipped: float
    pixels: int
    grain_visibility: float = 0.0


def material_features(
    patch: np.ndarray,
    mask: np.ndarray,
    belt_rgb_seen: np.ndarray,
    *,
    belt_rgb: tuple[float, ...],
    noise_sigma: float = 0.0,
) -> MaterialFeatures:
    """Grain and albedo features of one part.

    Parameters
    ----------
    patch : (H, W, 3) uint8 RGB image patch around the part.
    mask : (H, W) bool, the part's interior in ``patch`` (edges excluded).
    belt_rgb_seen : (3,) the belt's colour next to the part in the same image (grey levels).
    belt_rgb : the belt's nominal reflectance (0..1), the white-balance reference.
    noise_sigma : the frame's sensor noise per channel (grey levels), if known. Channels
        near black clip the noise, so the part's own noise estimate (across its colour) can
        read low; the larger of the two is used.

    The grain is measured on the high-pass residual (pixel minus its 3x3 mean), so smooth
    shading across a face does not count, with robust (median-based) scales, so the few
    pixels on a wall's edge do not count either. The filters see the patch mirrored at its
    border (``cv2.BORDER_REFLECT_101``): :func:`mosaic_features` on the patch padded so.
    """
    if not isinstance(patch, np.ndarray) or patch.ndim != 3 or patch.shape[2] != 3:
        raise VisionError(f"material_features: argument 'patch' must be (H, W, 3), got "
                          f"{getattr(patch, 'shape', type(patch).__name__)}")
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != patch.shape[:2]:
        raise VisionError(f"material_features: argument 'mask' must be {patch.shape[:2]}, "
                          f"got {mask.shape}")
    m8 = mask.view(np.uint8)
    n = cv2.countNonZero(m8)
    if n < 8:
        raise VisionError(f"material_features: argument 'mask' needs 8 pixels, got {n}")
    if patch.dtype != np.uint8:
        patch = np.clip(patch, 0, 255).astype(np.uint8)
    p = SUPPORT
    padded = cv2.copyMakeBorder(np.ascontiguousarray(patch), p, p, p, p, cv2.BORDER_REFLECT_101)
    at = np.flatnonzero(np.pad(mask, p))
    return mosaic_features(padded, at, [n], np.asarray(belt_rgb_seen, dtype=np.float64)[None],
                           belt_rgb=belt_rgb, noise_sigma=noise_sigma)[0]


def mosaic_features(
    img: np.ndarray,
    at: np.ndarray,
    counts: list[int],
    belt_rgb_seen: np.ndarray,
    *,
    belt_rgb: tuple[float, ...],
    noise_sigma: float = 0.0,
) -> list[MaterialFeatures]:
    """Grain and albedo features of several parts whose patches share one image.

    Parameters
    ----------
    img : (H, W, 3) uint8 RGB, a mosaic of the parts' patches. The features' filters (3x3
        mean, then 3x3 Sobel) read ``SUPPORT`` px around each part pixel, so what lies
        there must be that part's patch: its pixels in the frame, or the patch mirrored
        (``cv2.BORDER_REFLECT_101``) where it ends.
    at : (N,) int, the parts' pixels as flat indices into ``img``'s rows and columns,
        part after part, each part's in row-major order.
    counts : how many of ``at`` each part has (at least 8 each).
    belt_rgb_seen : (P, 3) the belt's colour next to each part (grey levels).
    belt_rgb, noise_sigma : as for :func:`material_features`.

    The filters run once over the whole mosaic, the robust statistics (``ndarray.partition``)
    on each part's run of pixels.
    """
    img = np.ascontiguousarray(img)
    starts = list(accumulate(counts[:-1], initial=0))
    pix = img.reshape(-1, 3).take(at, axis=0)
    means = np.add.reduceat(pix, starts, axis=0, dtype=np.float64)
    means *= [[1.0 / n] for n in counts]  # the integer sums times 1/n, as cv2.mean scales
    # Grain is measured where the surface is flat: shading (a bolt's curved flank, an edge
    # lit at a grazing angle) leaves a high-pass residual too, but varies smoothly, so it
    # shows in the gradient of the smoothed image; the flatter half of the part is kept.
    grey = cv2.blur(cv2.cvtColor(img, cv2.COLOR_RGB2GRAY), (3, 3))
    slope, gy = (g.reshape(-1).take(at).astype(np.int32) for g in cv2.spatialGradient(grey))
    slope *= slope
    gy *= gy
    slope += gy  # the 3x3 Sobel's (cv2.Sobel's) squared length: exact integers
    lit = grey.reshape(-1).take(at)
    slope_q = _upper_medians(slope.copy(), starts, counts)
    lit_q = _upper_medians(lit.copy(), starts, counts)
    flat = slope <= np.repeat(slope_q, counts)
    flat &= lit >= np.repeat(lit_q, counts)  # and the lit half: off the shadow terminator
    # the high-pass residual (pixel less its 3x3 mean) there only
    kept = np.flatnonzero(flat)
    local = cv2.blur(img, (3, 3)).reshape(-1, 3).take(at.take(kept), axis=0)
    resid = cv2.subtract(pix.take(kept, axis=0), local, dtype=cv2.CV_32F).reshape(-1, 1, 3)
    kept_n = np.add.reduceat(flat, starts, dtype=np.intp).tolist()
    norms = [math.sqrt(m @ m) for m in means]
    if min(norms) > 1e-6:
        units = means / np.array(norms)[:, None]
    else:  # a black part: any direction will do
        units = np.array([m / r if r > 1e-6 else np.full(3, 1 / math.sqrt(3))
                          for m, r in zip(means, norms, strict=True)])
    par, orth2 = _along_and_across(resid, units.astype(np.float32), kept_n)
    stats = _robust_scales(par, orth2, kept_n)
    unclipped = cv2.inRange(pix.reshape(-1, 1, 3), (0, 0, 0), (253, 253, 253)).reshape(-1)
    unclipped = np.add.reduceat(unclipped, starts, dtype=np.intp).tolist()
    albedo = means / np.maximum(np.asarray(belt_rgb_seen, dtype=np.float64), 1.0)
    albedo *= belt_rgb
    out = []
    for i, (n, m, norm, (s_par, s_noise2)) in enumerate(zip(counts, kept_n, norms, stats, strict=True)):
        s_noise = math.sqrt(max(s_noise2, 0.0)) / 1.1774  # Rayleigh median
        s_noise = max(s_noise, noise_sigma * _HIGHPASS_GAIN)
        grain_var = s_par**2 - s_noise**2
        se = math.sqrt(2.0 / (0.37 * max(m, 1))) * (s_par**2 + s_noise**2) + 1e-9
        out.append(MaterialFeatures(
            mean_rgb=means[i],
            albedo=albedo[i],
            grain=math.sqrt(max(grain_var, 0.0)) / max(norm / math.sqrt(3), 1.0),
            grain_z=grain_var / se,
            clipped=1.0 - unclipped[i] / (255 * n),  # = count / n: the same quotient
            pixels=n,
            grain_visibility=(0.05 * norm / math.sqrt(3)) ** 2 / se,
        ))
    return out


def _upper_medians(values: np.ndarray, starts: list[int], counts: list[int]) -> np.ndarray:
    """Element ``n // 2`` in order (``ndarray.partition``) of each run of ``values``; the
    runs are partitioned in place."""
    out = np.empty(len(counts), values.dtype)
    for i, (s, n) in enumerate(zip(starts, counts, strict=True)):
        run = values[s : s + n]
        run.partition(n // 2)
        out[i] = run[n // 2]
    return out


def _along_and_across(resid: np.ndarray, units: np.ndarray, counts: list[int]):
    """The residuals' (M, 1, 3) float32 component along their part's colour direction
    (``units`` (P, 3), ``cv2.transform`` part by part) and squared length across it."""
    par = np.empty(len(resid), np.float32)
    s = 0
    for i, n in enumerate(counts):
        cv2.transform(resid[s : s + n], units[i : i + 1], dst=par[s : s + n].reshape(-1, 1))
        s += n
    orth2 = cv2.transform(resid * resid, np.ones((1, 3), np.float32)).reshape(-1)
    orth2 -= par * par
    return par, orth2


def _robust_scales(par: np.ndarray, orth2: np.ndarray, counts: list[int]) -> list[tuple]:
    """Per run of ``counts``: (1.4826 * the MAD of ``par``, the upper median of ``orth2``),
    as Python floats; medians are element ``n // 2`` in order (``ndarray.partition``)."""
    starts = list(accumulate(counts[:-1], initial=0))
    meds = _upper_medians(par, starts, counts)  # in place: only each run's values count
    dev = np.abs(par - np.repeat(meds, counts))
    mads = _upper_medians(dev, starts, counts).tolist()
    return [(1.4826 * a, b)
            for a, b in zip(mads, _upper_medians(orth2, starts, counts).tolist(), strict=True)]


_FINISH_ALBEDO = np.array([
    np.array(m.rgba[:3]) * (_GRAIN_MEAN if m.material == "metal" else 1.0)
    for m in MATERIALS.values()
])
_FINISH_METAL = np.array([m.material == "metal" for m in MATERIALS.values()])


def _albedo_metal_probability(albedo: np.ndarray, sigma: float) -> np.ndarray:
    """P(metal) of each of (P, 3) albedos from the nearest catalogue finishes by
    white-balanced albedo (softmax).

    Metals' reference albedo is their colour times the grain's mean brightness.
    """
    d2 = ((_FINISH_ALBEDO - albedo[:, None]) ** 2).sum(axis=2) / sigma**2
    w = np.exp(-(d2 - d2.min(axis=1, keepdims=True)) / 2)
    return w[:, _FINISH_METAL].sum(axis=1) / w.sum(axis=1)


def classify_material(
    features: MaterialFeatures,
    *,
    backlit: bool,
    grain_metal: float,
    grain_z_min: float,
    albedo_sigma: float,
) -> tuple[str, float]:
    """``("metal" | "plastic" | "unknown", confidence)`` for one part.

    The albedo's nearest catalogue finishes give a prior P(metal) (Gaussian tolerance
    ``albedo_sigma``); grain then multiplies the odds: clear grain (``grain >= grain_metal``
    with ``grain_z >= grain_z_min``) on a surface bright enough to show it counts 50:1 for
    metal; grain below 0.45 * ``grain_metal`` where a metal's grain would be clearly
    visible (``grain_visibility`` >= 6) counts 1:50 against. The albedo prior is held
    within 0.05..0.95, so clear grain always wins. A back-lit part is ``unknown``
    (confidence 0): a silhouette shows neither cue.
    """
    return classify_materials([features], backlit=backlit, grain_metal=grain_metal,
                              grain_z_min=grain_z_min, albedo_sigma=albedo_sigma)[0]


def classify_materials(
    features: list[MaterialFeatures],
    *,
    backlit: bool,
    grain_metal: float,
    grain_z_min: float,
    albedo_sigma: float,
) -> list[tuple[str, float]]:
    """:func:`classify_material` of several parts (their albedo priors computed at once)."""
    if backlit or not features:
        return [("unknown", 0.0)] * len(features)
    albedo = np.array([f.albedo for f in features])
    prior = _albedo_metal_probability(albedo, albedo_sigma).tolist()
    bright = (albedo.sum(axis=1) / 3 >= 0.25).tolist()  # the mean, as ndarray.mean divides
    out = []
    for f, p, lit in zip(features, prior, bright, strict=True):
        # Albedo alone is never sure: specular light makes metal as bright as white plastic.
        p = min(max(p, 0.05), 0.95)
        odds = p / (1 - p)
        if lit and f.grain >= grain_metal and f.grain_z >= grain_z_min:
            odds *= 50.0
        elif lit and f.grain < 0.45 * grain_metal and f.grain_visibility >= 6.0:
            odds *= 0.02
        p = odds / (1 + odds)
        out.append(("metal", p) if p >= 0.5 else ("plastic", 1 - p))
    return out
