"""The material step's texture cue: how much grain a part's surface shows, free of the
sensor's noise (used by :mod:`cell.vision.steps.material`).

A machined metal surface has a fine grain that modulates the brightness of its own
colour; sensor noise is independent in each channel. Projecting each pixel's high-pass
residual (pixel minus its 3x3 mean) onto the direction of the part's mean colour gives
grain + noise; its length across that direction gives noise only (Rayleigh: median =
1.1774 sigma). The difference of the two variances estimates the grain free of the sensor
noise, with a standard error, so a dim, noisy frame does not fake grain (after the
colour-space noise model of Healey & Kondepudy, *Radiometric CCD camera calibration and
noise estimation*, 1994). Scales are robust (MAD, medians), and only the pixels both
flatter and brighter than the part's medians count (a third to a half of them, the two
being correlated): shading, a bolt's curved flank or the shadow terminator leave a
residual too, but show in the gradient of the smoothed grey.

:func:`interior_statistics` measures one part's interior (:class:`InteriorStats`);
:func:`grain_cues` turns the interiors of a frame's parts into their :class:`GrainCues`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["SUPPORT", "GrainCues", "InteriorStats", "grain_cues", "interior_statistics"]

SUPPORT = 2  # px the filters (3x3 mean, then 3x3 Sobel) read around a pixel
_HIGHPASS_GAIN = math.sqrt((8 / 9) ** 2 + 8 / 81)  # white noise through I - box3x3(I)


@dataclass(frozen=True)
class InteriorStats:
    """What :func:`interior_statistics` measures of one part's interior: ``pixels`` in it,
    ``grain_pixels`` of them kept for the grain (flat and lit), ``mean_rgb`` (3,) their
    mean colour (grey levels), ``along`` 1.4826 * the MAD of the high-pass residual along
    that colour (grain + noise), ``across2`` the median squared length of the residual
    across it (noise only), ``unclipped`` pixels with no channel above 253."""

    pixels: int
    grain_pixels: int
    mean_rgb: np.ndarray
    along: float
    across2: float
    unclipped: int

    @property
    def brightness(self) -> float:
        """The mean colour's length (grey levels)."""
        return float(np.sqrt(self.mean_rgb @ self.mean_rgb))


@dataclass(frozen=True)
class GrainCues:
    """The grain cues of P parts, each (P,): ``amplitude`` relative to the mean brightness,
    ``z`` its variance in standard errors, ``visibility`` (how many standard errors a
    metal's grain would stand out), ``even`` the share of the pixels kept for it."""

    amplitude: np.ndarray
    z: np.ndarray
    visibility: np.ndarray
    even: np.ndarray

    def unseen(self) -> GrainCues:
        """These cues with no evidence either way: no grain seen, nor any visible."""
        zero = np.zeros_like(self.z)
        return GrainCues(self.amplitude, zero, zero, self.even)


def interior_statistics(patch: np.ndarray, mask: np.ndarray) -> InteriorStats:
    """The :class:`InteriorStats` of the pixels ``mask`` (nonzero) of the uint8 RGB ``patch``,
    mirrored at its border (``cv2.BORDER_REFLECT_101``).

    Grey is ``cv2.COLOR_RGB2GRAY`` smoothed by a 3x3 mean (``cv2.blur``); a pixel is kept
    where its Sobel (``cv2.spatialGradient``) squared length is at most the part's median
    and its smoothed grey at least the median. The residual is the pixel minus its 3x3
    mean colour, in float32; medians are upper ones (element n // 2 in order)."""
    p = SUPPORT
    pad = cv2.copyMakeBorder(patch, p, p, p, p, cv2.BORDER_REFLECT_101)
    at = np.flatnonzero(cv2.copyMakeBorder(mask, p, p, p, p, cv2.BORDER_CONSTANT))
    n = len(at)
    pix = pad.reshape(-1, 3)[at]
    means = np.array(cv2.mean(patch, mask)[:3])  # (integer sums times 1 / n)
    grey = cv2.blur(cv2.cvtColor(pad, cv2.COLOR_RGB2GRAY), (3, 3))
    gx, gy = (g.reshape(-1)[at].astype(np.int32) for g in cv2.spatialGradient(grey))
    slope, lit = gx * gx + gy * gy, grey.reshape(-1)[at]
    flat = (slope <= _upper_median(slope)) & (lit >= _upper_median(lit))
    local = cv2.blur(pad, (3, 3)).reshape(-1, 3)[at[flat]]
    resid = cv2.subtract(pix[flat], local, dtype=cv2.CV_32F).reshape(-1, 1, 3)
    norm = float(np.sqrt(means @ means))
    unit = (means / norm if norm > 1e-6 else np.full(3, 1 / np.sqrt(3))).astype(np.float32)
    par = cv2.transform(resid, unit[None]).reshape(-1)
    orth2 = cv2.transform(resid * resid, np.ones((1, 3), np.float32)).reshape(-1) - par * par
    mad = _upper_median(np.abs(par - _upper_median(par)))
    unclipped = cv2.countNonZero(cv2.inRange(pix.reshape(-1, 1, 3), (0, 0, 0), (253, 253, 253)))
    return InteriorStats(pixels=n, grain_pixels=len(par), mean_rgb=means,
                         along=1.4826 * float(mad), across2=float(_upper_median(orth2)),
                         unclipped=unclipped)


def _upper_median(v: np.ndarray):
    """Element ``len(v) // 2`` of ``v`` in order (of two middle ones, the upper)."""
    return np.quantile(v, 0.5, method="higher")


def grain_cues(interiors: list[InteriorStats], sigma: float) -> GrainCues:
    """The :class:`GrainCues` of parts' interiors: the grain variance is that along the colour
    less the noise's (its scale across the colour, a Rayleigh median over 1.1774, floored
    at the frame's ``sigma`` through the high-pass), with its standard error."""
    norm = np.array([r.brightness for r in interiors])
    s_par = np.array([r.along for r in interiors])
    kept = np.array([r.grain_pixels for r in interiors], np.float64)
    pixels = np.array([r.pixels for r in interiors], np.float64)
    across2 = np.array([r.across2 for r in interiors])
    s_noise = np.maximum(np.sqrt(np.maximum(across2, 0.0)) / 1.1774, sigma * _HIGHPASS_GAIN)
    grain_var = s_par**2 - s_noise**2
    se = np.sqrt(2.0 / (0.37 * np.maximum(kept, 1.0))) * (s_par**2 + s_noise**2) + 1e-9
    grain = np.sqrt(np.maximum(grain_var, 0.0)) / np.maximum(norm / math.sqrt(3), 1.0)
    return GrainCues(amplitude=grain, z=grain_var / se,
                     visibility=(0.05 * norm / math.sqrt(3)) ** 2 / se, even=kept / pixels)
