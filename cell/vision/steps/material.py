"""Material step: metal, plastic or unknown for each part, from its own pixels.

Colour alone cannot tell grey or white plastic from steel or aluminium, nor yellow plastic
from brass, so the classifier looks at two cues that do not depend on hue:

* **Grain** (texture): a machined metal surface has a fine grain that modulates the
  brightness of its own colour, measured free of the sensor's noise, with a standard
  error, by :mod:`cell.vision.steps.grain`.
* **Albedo**. The part's mean colour divided by the belt's colour next to it, times the
  belt's known reflectance (a white balance against a reference surface of known colour),
  is compared with the catalogue's finishes (a softmax over squared distances); metals
  also read brighter under specular light. This decides when the grain is inconclusive.
  The sensor saturates its noise at 0 and 255, so a noisy dark channel's mean reads
  brighter and a bright one's darker (noise of 75 grey levels made yellow plastic brass):
  the part's mean and the belt's are taken back to before the clipping
  (:func:`cell.vision.colour.unclipped_mean`, with the frame's noise estimate).

The albedo gives a prior P(metal), held within 0.05..0.95; clear grain multiplies its
odds by 50, a surface that would clearly show a metal's grain but has none divides them
by 50. A colour no metal finish has (its chromaticity, the albedo over its sum, farther
than 0.12 from every metal's: a green or a saturated yellow) lowers the floor to 0.01, so
grain alone, which a moulded part's shading can fake under directional light, does not
make it metal; a brighter or darker reading (a white balance off under directional light)
leaves the chromaticity as it is. Under a back-light (or against a light table) a part is
a silhouette: neither cue exists and the material is ``"unknown"`` rather than a guess.
A sensor of fewer bits (:func:`~cell.vision.steps.foreground.grey_step`) truncates: every
mean is raised by half a step, and from steps of 8 grey levels (5 bits) the grain does
not count (finer than a step, it is gone, and its absence says nothing); with four levels
a channel or fewer (2 bits) there is no colour to read, and every material is unknown.
A frame with over 7.5 % impulse noise (salt and pepper; below it the robust scales hold)
is read through its 3x3 median, and the grain does not count (the median takes it out with
the specks): the albedo decides alone, within 0.05..0.95.
On a frame noisier than 20 grey levels the estimate of the noise reads low (much of it is
clipped: 79 for 90), so the labels are read again with 1.25x that noise, and a part whose
label changes is ``"unknown"`` too (else the lower of the two confidences).

Per part, :func:`part_materials` measures the interior, away from the edge's blend with
the belt (the mask eroded 5x5, or 3x3 where that leaves under 150 pixels: a square nut's
ring is 4 px wide), against the belt's colour next to it (the mean of the free pixels,
``foreground`` not 255, of the part's box grown by 6 px).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import cv2
import numpy as np

from cell.catalogue import MATERIALS
from cell.errors import VisionError
from cell.vision._checks import check_range
from cell.vision.colour import unclipped_mean
from cell.vision.settings import VisionSettings
from cell.vision.steps.foreground import grey_step, noise_sigma
from cell.vision.steps.grain import (
    SUPPORT,
    GrainCues,
    InteriorStats,
    grain_cues,
    interior_statistics,
)

__all__ = ["MaterialFeatures", "MaterialLabel", "PartPixels", "classify_material",
           "material_features", "part_materials"]


class MaterialLabel(NamedTuple):
    """What the material step says of one part: ``material`` (``metal``, ``plastic`` or
    ``unknown``) and its ``confidence`` (0..1; 0 for ``unknown``)."""

    material: str
    confidence: float


_UNKNOWN = MaterialLabel("unknown", 0.0)
_RING, _MIN_FREE = 6, 30  # belt window: the box grown by 6 px; fewer free pixels: not measured
_MIN_PIXELS, _WIDE = 8, 150  # interior pixels needed at all; below _WIDE, erode 3x3 not 5x5
_GRAIN_ODDS = 50.0  # the odds clear grain (or its clear absence) multiplies
_SOFT_Z = 0.5  # standard errors below grain_z_min over which grain's weight rises
_WEAK, _Z_PER_DEFICIT, _EVEN = 0.5, 2.0, 0.18  # weak grain: see _grain_evidence
_VISIBLE = 4.0  # grain visibility (standard errors) at which its absence counts against metal
_GRAIN_MEAN = 0.9  # a metal grain's mean brightness factor (texture mean over texels)
_FINISH_ALBEDO = np.array([np.array(m.rgba[:3]) * (_GRAIN_MEAN if m.material == "metal" else 1.0)
                           for m in MATERIALS.values()])
_FINISH_METAL = np.array([m.material == "metal" for m in MATERIALS.values()])
_PRIOR_FLOOR, _OFF_HUE_FLOOR = 0.05, 0.01  # the prior's floor; for a colour no metal has
_OFF_HUE = 0.12  # chromaticity distance from every metal finish's that no metal reads at
_GRAINLESS_STEP = 8  # grey levels: a frame quantised this coarsely (5 bits) shows no grain
_COLOURLESS_STEP = 64  # grey levels: nor any colour (2 bits: four levels a channel)
_GRAINLESS_IMPULSES = 0.075  # a frame with more impulse noise than this share: no grain
_CLIPPING = 20.0  # grey levels: a noisier frame has its colours read again at _SIGMA_LOW x
_SIGMA_LOW = 1.25  # the noise the frame's estimate may hide where the sensor clips it


def _chromaticity(rgb: np.ndarray) -> np.ndarray:
    """Each colour (..., 3) over its sum: its hue and saturation, free of brightness."""
    return rgb / np.maximum(rgb.sum(axis=-1, keepdims=True), 1e-9)


_METAL_CHROMATICITY = _chromaticity(_FINISH_ALBEDO[_FINISH_METAL])


@dataclass(frozen=True)
class PartPixels:
    """One part's own pixels: ``mask`` uint8 (h, w), nonzero on the part, whose top-left
    corner lies at (x0, y0) of the frame (pixels)."""

    x0: int
    y0: int
    mask: np.ndarray


@dataclass(frozen=True)
class MaterialFeatures:
    """What the material classifier looks at, for one part.

    ``mean_rgb`` the mean colour (grey levels); ``albedo`` the white-balanced reflectance
    per channel (0..1, may exceed 1 under specular light); ``grain`` the grain amplitude
    relative to the mean brightness (0 for a smooth surface); ``grain_z`` the grain
    variance in units of its standard error (evidence that grain exists); ``clipped`` the
    fraction of saturated pixels; ``pixels`` how many pixels were used;
    ``grain_visibility`` how many standard errors a metal's grain (5 % of the brightness)
    would stand above the noise here: where it is small (dim, noisy, tiny), the absence of
    grain says nothing; ``grain_pixels`` how many of the pixels the grain was measured on
    (the flatter, lit ones: about half of an evenly lit surface).
    """

    mean_rgb: np.ndarray
    albedo: np.ndarray
    grain: float
    grain_z: float
    clipped: float
    pixels: int
    grain_visibility: float = 0.0
    grain_pixels: int = 0


def part_materials(image: np.ndarray, foreground: np.ndarray, parts: list[PartPixels], *,
                   settings: VisionSettings, backlit: bool, impulses: float = 0.0
                   ) -> list[MaterialLabel]:
    """The :class:`MaterialLabel` of each part (module docstring).
    ``image`` uint8 RGB (H, W, 3); ``foreground`` uint8 (H, W), 255 on any part's pixels.
    Under 30 free pixels around a part, the belt's colour is the median colour of the free
    pixels of the whole frame (a median: the sensor's clipping leaves it be; the means are
    taken back, :func:`cell.vision.colour.unclipped_mean`). ``unknown`` (confidence 0) for a
    back-lit frame, an interior under 8 pixels, a belt (or a frame without free pixels) at
    ``backlight_level`` or brighter in every channel (a light table), or a label that
    changes when a frame's noise over 20 grey levels is read 1.25x higher. ``impulses`` the
    share of the frame's pixels that are impulse noise (salt and pepper,
    :func:`~cell.vision.steps.foreground.impulse_share`, 0 to 1): up to 7.5 % the robust
    scales hold and the frame is read as it is; above, its 3x3 median is read instead, and
    without grain (the median takes it out too): the albedo alone decides."""
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.shape[2:] != (3,):
        raise VisionError(f"part_materials: argument 'image' must be uint8 (H, W, 3), got "
                          f"{getattr(image, 'shape', type(image).__name__)}")
    if not isinstance(foreground, np.ndarray) or foreground.shape != image.shape[:2]:
        raise VisionError(f"part_materials: argument 'foreground' must be {image.shape[:2]}, "
                          f"got {getattr(foreground, 'shape', type(foreground).__name__)}")
    if not isinstance(settings, VisionSettings):
        raise VisionError(f"part_materials: argument 'settings' must be VisionSettings, got "
                          f"{type(settings).__name__}")
    impulses = check_range("impulses", impulses, 0.0, 1.0)
    grain = impulses <= _GRAINLESS_IMPULSES
    if not grain:
        image = cv2.medianBlur(image, 3)
    step = grey_step(image)
    if step >= _COLOURLESS_STEP:  # four grey levels a channel or fewer: no colour to read
        return [_UNKNOWN] * len(parts)
    grain = grain and step < _GRAINLESS_STEP  # a metal's grain is finer than 8 grey levels
    out = [_UNKNOWN] * len(parts)
    rows, interiors, belts, belt_means = [], [], [], []
    frame_belt = None  # the median of the frame's free pixels, on first need
    for i, part in enumerate([] if backlit else parts):
        if (inner := _interior(image, part)) is None:
            continue
        n_free, belt = _belt_colour(image, foreground, part)
        if n_free < _MIN_FREE:  # hardly any belt around the part
            if frame_belt is None:
                free = image[foreground != 255]
                frame_belt = np.median(free, axis=0) if len(free) else np.full(3, np.inf)
            belt = frame_belt
        if belt.min() < settings.backlight_level:  # (else a light table: a silhouette)
            rows.append(i)
            interiors.append(interior_statistics(*inner))
            belts.append(belt)
            belt_means.append(belt is not frame_belt)
    if rows:
        belts, sigma = np.array(belts), noise_sigma(image)
        means = np.array([r.mean_rgb for r in interiors])
        means += (step - 1) / 2  # a sensor that truncates reads darker
        belts += (step - 1) / 2
        seen = _Seen(interiors, means, belts, np.array(belt_means))
        labels = _frame_labels(seen, sigma, settings, grain)
        if sigma > _CLIPPING:  # the decision must not hang on the noise estimate
            alt = _frame_labels(seen, sigma * _SIGMA_LOW, settings, grain)
            labels = [MaterialLabel(a.material, min(a.confidence, b.confidence))
                      if a.material == b.material else _UNKNOWN
                      for a, b in zip(labels, alt, strict=True)]
        for i, label in zip(rows, labels, strict=True):
            out[i] = label
    return out


@dataclass(frozen=True)
class _Seen:
    """What one frame shows of P parts: their ``interiors``, mean colours ``means`` (P, 3)
    and the belt's colour next to each, ``belts`` (P, 3, grey levels; each a mean where
    ``belt_means`` (P,) is True, else the frame's median)."""

    interiors: list[InteriorStats]
    means: np.ndarray
    belts: np.ndarray
    belt_means: np.ndarray


def _frame_labels(seen: _Seen, sigma: float, settings: VisionSettings, grain: bool
                  ) -> list[MaterialLabel]:
    """Labels of the parts ``seen`` in a frame of sensor noise ``sigma`` (grey levels); the
    means, not the medians, are taken back to before the sensor clipped that noise
    (:func:`unclipped_mean`); ``grain`` False: the grain counts neither way."""
    belts, clip = seen.belts.copy(), min(sigma, 255.0)  # (a crafted frame's estimate may read more)
    belts[seen.belt_means] = unclipped_mean(belts[seen.belt_means], sigma=clip)
    means = unclipped_mean(seen.means, sigma=clip)
    cues = grain_cues(seen.interiors, sigma)
    return _labels(_albedo(means, belts, settings.belt_rgb), cues if grain else cues.unseen(),
                   grain_metal=settings.grain_metal, grain_z_min=settings.grain_z_min,
                   albedo_sigma=settings.albedo_sigma)


def material_features(patch: np.ndarray, mask: np.ndarray, belt_rgb_seen: np.ndarray, *,
                      belt_rgb: tuple[float, ...], noise_sigma: float = 0.0) -> MaterialFeatures:
    """Grain and albedo features of one part: ``patch`` (H, W, 3) RGB around it (the
    filters see it mirrored at its border, ``cv2.BORDER_REFLECT_101``), ``mask`` (H, W)
    bool its interior (edges excluded, at least 8 pixels), ``belt_rgb_seen`` (3,) the belt's
    colour next to it (grey levels), ``belt_rgb`` the belt's reflectance (0..1), the
    white-balance reference, ``noise_sigma`` the frame's sensor noise (grey levels) if known:
    channels near black clip the noise, so the part's own estimate (across its colour) can
    read low; the larger of the two is used. The part's mean colour and ``belt_rgb_seen``
    (taken as a mean) are taken back to before the sensor clipped that noise
    (:func:`cell.vision.colour.unclipped_mean`) for the albedo; ``mean_rgb`` is as measured.

    ``patch`` uint8 (H, W, 3); ``mask`` bool or uint8 (H, W), nonzero inside;
    ``belt_rgb_seen`` three finite numbers in 0..255; ``belt_rgb`` three numbers in
    (0, 1]; ``noise_sigma`` a number in 0..255. Anything else is a ``VisionError`` naming
    the argument. (The detector measures its parts through :func:`part_materials`.)"""
    if (not isinstance(patch, np.ndarray) or patch.dtype != np.uint8 or patch.ndim != 3
            or patch.shape[2] != 3):
        raise VisionError(f"material_features: argument 'patch' must be uint8 (H, W, 3), got "
                          f"{getattr(patch, 'dtype', type(patch).__name__)} "
                          f"{getattr(patch, 'shape', '')}")
    if (not isinstance(mask, np.ndarray) or mask.dtype not in (np.bool_, np.uint8)
            or mask.shape != patch.shape[:2]):
        raise VisionError(f"material_features: argument 'mask' must be bool or uint8 "
                          f"{patch.shape[:2]}, got {getattr(mask, 'dtype', type(mask).__name__)} "
                          f"{getattr(mask, 'shape', '')}")
    mask = mask.astype(bool, copy=False)
    if (n := int(np.count_nonzero(mask))) < _MIN_PIXELS:
        raise VisionError(f"material_features: argument 'mask' needs 8 pixels, got {n}")
    belt_rgb_seen = _three("belt_rgb_seen", belt_rgb_seen, 0.0, 255.0)
    belt_rgb = _three("belt_rgb", belt_rgb, 0.0, 1.0)
    if not belt_rgb.min() > 0:
        raise VisionError(f"material_features: argument 'belt_rgb' must be above 0 in every "
                          f"channel (a reflectance in (0, 1]), got {tuple(belt_rgb.tolist())}")
    noise_sigma = check_range("noise_sigma", noise_sigma, 0.0, 255.0)
    inner = interior_statistics(np.ascontiguousarray(patch), np.ascontiguousarray(mask).view(np.uint8))
    cues = grain_cues([inner], noise_sigma)
    mean = inner.mean_rgb
    albedo = _albedo(*(unclipped_mean(m, sigma=noise_sigma) for m in (mean, belt_rgb_seen)), belt_rgb)
    return MaterialFeatures(mean_rgb=mean, albedo=albedo, grain=float(cues.amplitude[0]),
                            grain_z=float(cues.z[0]), clipped=1.0 - inner.unclipped / inner.pixels,
                            pixels=inner.pixels, grain_visibility=float(cues.visibility[0]),
                            grain_pixels=inner.grain_pixels)


def classify_material(features: MaterialFeatures, *, backlit: bool, grain_metal: float,
                      grain_z_min: float, albedo_sigma: float) -> MaterialLabel:
    """The :class:`MaterialLabel` of one part: the albedo's nearest
    catalogue finishes give a prior P(metal) (Gaussian tolerance ``albedo_sigma``), held
    within 0.05..0.95 (from 0.01 for a colour no metal has); grain then multiplies the
    odds: clear grain (``grain >= grain_metal`` with ``grain_z >= grain_z_min``) on a
    surface bright enough to show it counts 50:1 for metal; grain below 0.45 *
    ``grain_metal`` where a metal's grain would be clearly visible (``grain_visibility`` >= 4)
    counts 1:50 against. Back-lit: ``unknown``, 0.

    ``features`` a :class:`MaterialFeatures` with finite values; ``backlit`` a bool;
    ``grain_metal`` in [0, 1], ``grain_z_min`` in [0, 100], ``albedo_sigma`` in
    [0.001, 1] (the ranges of :class:`VisionSettings`)."""
    if not isinstance(features, MaterialFeatures):
        raise VisionError(f"classify_material: argument 'features' must be MaterialFeatures, "
                          f"got {type(features).__name__}")
    if not isinstance(backlit, bool | np.bool_):
        raise VisionError(f"classify_material: argument 'backlit' must be True or False, "
                          f"got {backlit!r}")
    check_range("grain_metal", grain_metal, 0.0, 1.0)
    check_range("grain_z_min", grain_z_min, 0.0, 100.0)
    check_range("albedo_sigma", albedo_sigma, 0.001, 1.0)
    f = features
    try:
        albedo = np.asarray(f.albedo, dtype=np.float64)
        fields = np.array([f.grain, f.grain_z, f.grain_visibility, f.grain_pixels, f.pixels],
                          dtype=np.float64)
    except (TypeError, ValueError):
        albedo = fields = np.array([np.nan])
    if albedo.shape != (3,) or not (np.isfinite(albedo).all() and np.isfinite(fields).all()):
        raise VisionError("classify_material: argument 'features' must hold finite numbers "
                          "(albedo three of them)")
    if backlit:
        return _UNKNOWN
    cues = GrainCues(amplitude=np.array([f.grain], np.float64),
                     z=np.array([f.grain_z], np.float64),
                     visibility=np.array([f.grain_visibility], np.float64),
                     even=np.array([f.grain_pixels / max(f.pixels, 1)], np.float64))
    return _labels(np.asarray(f.albedo, np.float64)[None], cues, grain_metal=grain_metal,
                   grain_z_min=grain_z_min, albedo_sigma=albedo_sigma)[0]


def _three(name: str, value: object, lo: float, hi: float) -> np.ndarray:
    """Three finite numbers in [lo, hi] (one per channel) as float64 (3,)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.full(1, np.nan)
    if arr.shape != (3,) or not (np.isfinite(arr).all() and lo <= arr.min() and arr.max() <= hi):
        raise VisionError(f"material_features: argument '{name}': expected three numbers in "
                          f"[{lo:g}, {hi:g}] (R, G, B), got {value!r}")
    return arr


def _interior(image: np.ndarray, part: PartPixels) -> tuple[np.ndarray, np.ndarray] | None:
    """(patch, mask) of the part's interior: its mask eroded (``cv2.erode``, whose default
    border does not eat into the mask's box), cropped to the interior's bounding box and
    ``SUPPORT`` px around it (within the mask's box), and the frame's pixels there; None
    under 8 pixels."""
    if not isinstance(part, PartPixels) or not isinstance(part.mask, np.ndarray) or part.mask.ndim != 2:
        raise VisionError(f"part_materials: argument 'parts' must hold PartPixels with a 2-D "
                          f"mask, got {type(part).__name__}")
    (h, w), (x0, y0) = part.mask.shape, (part.x0, part.y0)
    if x0 < 0 or y0 < 0 or x0 + w > image.shape[1] or y0 + h > image.shape[0]:
        raise VisionError(f"part_materials: argument 'parts': a {w}x{h} mask at ({x0}, {y0}) "
                          f"leaves the {image.shape[1]}x{image.shape[0]} frame")
    mask = part.mask.astype(np.uint8, copy=False)
    inner = cv2.erode(mask, np.ones((5, 5), np.uint8))
    if cv2.countNonZero(inner) < _WIDE:
        inner = cv2.erode(mask, np.ones((3, 3), np.uint8))
        if cv2.countNonZero(inner) < _MIN_PIXELS:
            return None
    bx, by, bw, bh = cv2.boundingRect(inner)
    xa, ya = max(bx - SUPPORT, 0), max(by - SUPPORT, 0)
    xb, yb = min(bx + bw + SUPPORT, w), min(by + bh + SUPPORT, h)
    return image[y0 + ya : y0 + yb, x0 + xa : x0 + xb], inner[ya:yb, xa:xb]


def _belt_colour(image: np.ndarray, foreground: np.ndarray, part: PartPixels) -> tuple[int, np.ndarray]:
    """(free pixels, their mean colour) of the part's box grown by ``_RING`` px (clipped to
    the frame): integer sums times 1 / n, as ``cv2.mean``."""
    h, w = part.mask.shape
    ya, xa = max(part.y0 - _RING, 0), max(part.x0 - _RING, 0)
    win = np.s_[ya : part.y0 + h + _RING, xa : part.x0 + w + _RING]
    free = (foreground[win] != 255).view(np.uint8)
    n = cv2.countNonZero(free)
    return n, np.array(cv2.mean(image[win], free)[:3])


def _albedo(means: np.ndarray, belt_seen: np.ndarray, belt_rgb: tuple[float, ...]) -> np.ndarray:
    """White-balanced albedo: the mean colour over the belt's (at least 1), times its reflectance."""
    return means / np.maximum(np.asarray(belt_seen, np.float64), 1.0) * np.asarray(belt_rgb)


def _grain_evidence(grain: np.ndarray, z: np.ndarray, even: np.ndarray, *, grain_metal: float,
                    grain_z_min: float) -> np.ndarray:
    """How much of the grain's full weight (0..1) each part's grain carries: full from
    ``grain_metal`` and ``grain_z_min``, rising linearly over the last ``_SOFT_Z`` standard
    errors below that (one interior pixel more or less does not flip a label). A weaker
    grain, down to ``_WEAK`` * ``grain_metal`` (a metal under a specular spot), counts
    with ``_Z_PER_DEFICIT`` standard errors more at half ``grain_metal``, and only on an
    evenly lit surface (at least ``_EVEN`` of its pixels flat and lit: under directional
    light a thread's shading passes for weak grain)."""
    deficit = 1.0 - grain / grain_metal if grain_metal > 0 else 0.0  # (unused at grain_metal 0)
    need = np.where(grain >= grain_metal, grain_z_min, grain_z_min + _Z_PER_DEFICIT * deficit)
    weak = (grain < grain_metal) & ((grain < _WEAK * grain_metal) | (even < _EVEN))
    return np.where(weak, 0.0, np.clip((z - need) / _SOFT_Z + 1.0, 0.0, 1.0))


def _labels(albedo: np.ndarray, grain: GrainCues, *, grain_metal: float, grain_z_min: float,
            albedo_sigma: float) -> list[MaterialLabel]:
    """Labels of parts from their albedos (P, 3) and grain cues (:func:`grain_cues`):
    the albedo's softmax prior over the catalogue finishes, held within 0.05..0.95 (0.01..0.95
    for a colour no metal has), its odds multiplied by the grain's evidence (see
    :func:`classify_material`)."""
    d2 = ((_FINISH_ALBEDO - albedo[:, None]) ** 2).sum(axis=2) / albedo_sigma**2
    w = np.exp(-(d2 - d2.min(axis=1, keepdims=True)) / 2)
    hue_off = np.linalg.norm(_chromaticity(albedo)[:, None] - _METAL_CHROMATICITY, axis=2).min(axis=1)
    floor = np.where(hue_off > _OFF_HUE, _OFF_HUE_FLOOR, _PRIOR_FLOOR)
    prior = np.clip(w[:, _FINISH_METAL].sum(axis=1) / w.sum(axis=1), floor, 1 - _PRIOR_FLOOR)
    g, z, vis, even = grain.amplitude, grain.z, grain.visibility, grain.even
    lit = albedo.mean(axis=1) >= 0.25
    evidence = np.where(lit, _grain_evidence(g, z, even, grain_metal=grain_metal,
                                             grain_z_min=grain_z_min), 0.0)
    odds = prior / (1 - prior) * np.where(evidence > 0.0, _GRAIN_ODDS**evidence, 1.0)
    odds *= np.where((evidence <= 0.0) & lit & (g < 0.45 * grain_metal) & (vis >= _VISIBLE),
                     1.0 / _GRAIN_ODDS, 1.0)
    return [MaterialLabel("metal", q) if q >= 0.5 else MaterialLabel("plastic", 1 - q)
            for q in (odds / (1 + odds)).tolist()]
