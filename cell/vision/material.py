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

import cv2
import numpy as np

from cell.catalogue import MATERIALS
from cell.errors import VisionError

__all__ = ["MaterialFeatures", "classify_material", "material_features"]

_GRAIN_MEAN = 0.9  # the metal grain's mean brightness factor (texture mean over texels)


@dataclass(frozen=True)
class MaterialFeatures:
    """What the material classifier looks at, for one part.

    ``mean_rgb`` the mean colour (grey levels); ``albedo`` the white-balanced reflectance
    per channel (0..1, may exceed 1 under specular light); ``grain`` the grain amplitude
    relative to the mean brightness (0 for a smooth surface); ``grain_z`` the grain
    variance in units of its standard error (evidence that grain exists); ``clipped``
    the fraction of saturated pixels; ``pixels`` how many pixels were used.
    """

    mean_rgb: np.ndarray
    albedo: np.ndarray
    grain: float
    grain_z: float
    clipped: float
    pixels: int


def material_features(
    patch: np.ndarray, mask: np.ndarray, belt_rgb_seen: np.ndarray, *, belt_rgb: tuple[float, ...]
) -> MaterialFeatures:
    """Grain and albedo features of one part.

    Parameters
    ----------
    patch : (H, W, 3) uint8 RGB image patch around the part.
    mask : (H, W) bool, the part's interior in ``patch`` (edges excluded).
    belt_rgb_seen : (3,) the belt's colour next to the part in the same image (grey levels).
    belt_rgb : the belt's nominal reflectance (0..1), the white-balance reference.

    The grain is measured on the high-pass residual (pixel minus its 3x3 mean), so smooth
    shading across a face does not count, with robust (median-based) scales, so the few
    pixels on a wall's edge do not count either.
    """
    if not isinstance(patch, np.ndarray) or patch.ndim != 3 or patch.shape[2] != 3:
        raise VisionError(f"material_features: argument 'patch' must be (H, W, 3), got "
                          f"{getattr(patch, 'shape', type(patch).__name__)}")
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != patch.shape[:2]:
        raise VisionError(f"material_features: argument 'mask' must be {patch.shape[:2]}, "
                          f"got {mask.shape}")
    n = int(mask.sum())
    if n < 8:
        raise VisionError(f"material_features: argument 'mask' needs 8 pixels, got {n}")
    img = patch.astype(np.float32)
    px = img[mask].astype(np.float64)
    belt_seen = np.maximum(np.asarray(belt_rgb_seen, dtype=np.float64), 1.0)
    mean = px.mean(axis=0)
    norm = float(np.linalg.norm(mean))
    u = mean / norm if norm > 1e-6 else np.full(3, 1 / math.sqrt(3))
    hp = (img - cv2.blur(img, (3, 3)))[mask].astype(np.float64)
    par = hp @ u
    orth = np.linalg.norm(hp - par[:, None] * u, axis=1)
    s_par = 1.4826 * float(np.median(np.abs(par - np.median(par))))
    s_noise = float(np.median(orth)) / 1.1774  # Rayleigh median -> per-axis sigma
    grain_var = s_par**2 - s_noise**2
    se = math.sqrt(2.0 / (0.37 * n)) * (s_par**2 + s_noise**2) + 1e-9
    albedo = mean / belt_seen * np.asarray(belt_rgb, dtype=np.float64)
    return MaterialFeatures(
        mean_rgb=mean,
        albedo=albedo,
        grain=math.sqrt(max(grain_var, 0.0)) / max(norm / math.sqrt(3), 1.0),
        grain_z=grain_var / se,
        clipped=float((px >= 254).any(axis=1).mean()),
        pixels=n,
    )


def _albedo_metal_probability(albedo: np.ndarray, sigma: float) -> float:
    """P(metal) from the nearest catalogue finishes by white-balanced albedo (softmax)."""
    names = list(MATERIALS)
    ref = np.array([
        np.array(MATERIALS[m].rgba[:3]) * (_GRAIN_MEAN if MATERIALS[m].material == "metal" else 1)
        for m in names
    ])
    d2 = ((ref - albedo) ** 2).sum(axis=1) / sigma**2
    w = np.exp(-(d2 - d2.min()) / 2)
    metal = np.array([MATERIALS[m].material == "metal" for m in names])
    p = float(w[metal].sum() / w.sum())
    # Brighter than any matte finish can be: a specular reflection, so metal.
    if albedo.mean() > 1.05:
        p = max(p, 0.9)
    return p


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
    metal, a well-sampled bright surface with no grain 1:10 against. A back-lit part is
    ``unknown`` (confidence 0): a silhouette shows neither cue.
    """
    if backlit:
        return "unknown", 0.0
    f = features
    p = min(max(_albedo_metal_probability(f.albedo, albedo_sigma), 1e-6), 1 - 1e-6)
    odds = p / (1 - p)
    bright = float(f.albedo.mean()) >= 0.25
    if bright and f.grain >= grain_metal and f.grain_z >= grain_z_min:
        odds *= 50.0
    elif bright and f.grain_z < 1.0 and f.grain < 0.5 * grain_metal and f.pixels >= 150:
        odds *= 0.1
    p = odds / (1 + odds)
    return ("metal", p) if p >= 0.5 else ("plastic", 1 - p)
