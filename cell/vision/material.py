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

from dataclasses import dataclass

import numpy as np

from cell.catalogue import MATERIALS
from cell.errors import VisionError
from cell.vision._material_kernel import (
    KEPT,
    MEAN,
    UNCLIPPED,
    N,
    patch_statistics,
)
from cell.vision._material_labels import (
    grain_rows,
    metal_odds,
    metal_prior,
    metal_probabilities,
)

__all__ = ["MaterialFeatures", "classify_material", "classify_materials",
           "features_from_statistics", "material_features", "materials_from_statistics"]

_GRAIN_MEAN = 0.9  # the metal grain's mean brightness factor (texture mean over texels)


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
    grain says nothing; ``grain_pixels`` how many of the pixels the grain was measured on
    (the flatter, lit ones: about a quarter of an evenly lit surface, fewer under
    directional light).
    """

    mean_rgb: np.ndarray
    albedo: np.ndarray
    grain: float
    grain_z: float
    clipped: float
    pixels: int
    grain_visibility: float = 0.0
    grain_pixels: int = 0


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
    pixels on a wall's edge do not count either; only the flatter, lit half of the part's
    pixels is used (shading, a bolt's curved flank or an edge lit at a grazing angle,
    leaves a high-pass residual too, but shows in the gradient of the smoothed grey).
    The filters see the patch mirrored at its border (``cv2.BORDER_REFLECT_101``); the
    pixel statistics are :func:`cell.vision._material_kernel.patch_statistics`'.
    """
    if not isinstance(patch, np.ndarray) or patch.ndim != 3 or patch.shape[2] != 3:
        raise VisionError(f"material_features: argument 'patch' must be (H, W, 3), got "
                          f"{getattr(patch, 'shape', type(patch).__name__)}")
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != patch.shape[:2]:
        raise VisionError(f"material_features: argument 'mask' must be {patch.shape[:2]}, "
                          f"got {mask.shape}")
    n = int(np.count_nonzero(mask))
    if n < 8:
        raise VisionError(f"material_features: argument 'mask' needs 8 pixels, got {n}")
    if patch.dtype != np.uint8:
        patch = np.clip(patch, 0, 255).astype(np.uint8)
    stats = patch_statistics(np.ascontiguousarray(patch),
                             np.ascontiguousarray(mask.view(np.uint8)))
    return features_from_statistics(stats[None], np.asarray(belt_rgb_seen, np.float64)[None],
                                    belt_rgb=belt_rgb, noise_sigma=noise_sigma)[0]


def features_from_statistics(
    stats: np.ndarray,
    belt_rgb_seen: np.ndarray,
    *,
    belt_rgb: tuple[float, ...],
    noise_sigma: float = 0.0,
) -> list[MaterialFeatures]:
    """Grain and albedo features of parts from their pixel statistics.

    Parameters
    ----------
    stats : (P, N_STATS) float, rows of :mod:`cell.vision._material_kernel`: pixels,
        pixels kept for the grain, mean RGB, its length, the scales of the residual along
        and across the mean colour, unclipped pixels.
    belt_rgb_seen : (P, 3) the belt's colour next to each part (grey levels).
    belt_rgb, noise_sigma : as for :func:`material_features`.

    Grain and noise: the residual's component along the part's colour holds grain +
    noise, its length across only noise (Rayleigh: median = 1.1774 sigma); grain
    variance = difference of the two variances, with its standard error.
    """
    means = stats[:, MEAN : MEAN + 3]
    albedo = _albedo(means, belt_rgb_seen, belt_rgb)
    return [
        MaterialFeatures(mean_rgb=means[i], albedo=albedo[i], grain=grain, grain_z=z,
                         clipped=1.0 - row[UNCLIPPED] / row[N], pixels=int(row[N]),
                         grain_visibility=vis, grain_pixels=int(row[KEPT]))
        for i, (row, (grain, z, vis, _)) in enumerate(
            zip(stats.tolist(), _grain(stats, noise_sigma).tolist(), strict=True))
    ]


def materials_from_statistics(
    stats: np.ndarray,
    belt_rgb_seen: np.ndarray,
    *,
    belt_rgb: tuple[float, ...],
    noise_sigma: float,
    grain_metal: float,
    grain_z_min: float,
    albedo_sigma: float,
) -> list[tuple[str, float]]:
    """:func:`classify_materials` of :func:`features_from_statistics` (arguments as
    there), without building the features."""
    p = np.empty(len(stats))
    metal_probabilities(np.ascontiguousarray(stats, dtype=np.float64),
                        np.ascontiguousarray(belt_rgb_seen, dtype=np.float64),
                        np.asarray(belt_rgb, dtype=np.float64), float(noise_sigma), 2.0,
                        float(grain_metal), float(grain_z_min), _FINISH_ALBEDO, _FINISH_METAL,
                        albedo_sigma**2, p)
    return [("metal", q) if q >= 0.5 else ("plastic", 1 - q) for q in p.tolist()]


def _albedo(means: np.ndarray, belt_rgb_seen: np.ndarray, belt_rgb: tuple[float, ...]):
    """White-balanced albedo (P, 3): the mean colour over the belt's, times its reflectance."""
    albedo = means / np.maximum(np.asarray(belt_rgb_seen, dtype=np.float64), 1.0)
    albedo *= belt_rgb
    return albedo


def _grain(stats: np.ndarray, noise_sigma: float) -> np.ndarray:
    """(grain, grain_z, grain_visibility, grain_pixels / pixels) (P, 4) of statistics rows
    (see MaterialFeatures; compiled: :func:`cell.vision._material_labels.grain_rows`)."""
    out = np.empty((len(stats), 4))
    grain_rows(np.ascontiguousarray(stats, dtype=np.float64), float(noise_sigma), 2.0, out)
    return out


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
    return metal_prior(np.ascontiguousarray(albedo, dtype=np.float64), _FINISH_ALBEDO,
                       _FINISH_METAL, sigma**2)


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
    return _labels(np.array([f.albedo for f in features]),
                   np.array([(f.grain, f.grain_z, f.grain_visibility,
                              f.grain_pixels / max(f.pixels, 1)) for f in features]),
                   grain_metal, grain_z_min, albedo_sigma)


def _labels(albedo: np.ndarray, grain: np.ndarray, grain_metal: float, grain_z_min: float,
            albedo_sigma: float) -> list[tuple[str, float]]:
    """Labels of parts from their albedos (P, 3) and grain rows (P, 4: grain, grain_z,
    grain_visibility, even-light fraction). Albedo alone is never sure (specular light
    makes metal as bright as white plastic): the prior is held within 0.05..0.95 before
    the grain multiplies its odds (compiled: :func:`cell.vision._material_labels.metal_odds`)."""
    albedo = np.ascontiguousarray(albedo, dtype=np.float64)
    p = np.empty(len(albedo))
    metal_odds(albedo, np.ascontiguousarray(grain, dtype=np.float64),
               _albedo_metal_probability(albedo, albedo_sigma), float(grain_metal),
               float(grain_z_min), p)
    return [("metal", q) if q >= 0.5 else ("plastic", 1 - q) for q in p.tolist()]
