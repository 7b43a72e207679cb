"""Colour conversion (HSV, CIE Lab) and colour statistics of a region.

Statistics only: the metal/plastic classifier lives in ``cell.vision.steps.material``.
Conversions run in float32 so the units are the textbook ones: H in degrees
[0, 360), S and V in [0, 1], L* in [0, 100], a* and b* roughly [-127, 127]
(D65 white, sRGB gamma, as ``cv2.cvtColor`` computes for float images).

References: A. R. Smith, "Color gamut transform pairs", SIGGRAPH 1978 (HSV);
CIE 15:2004 (L*a*b*); Gonzalez & Woods, *Digital Image Processing*, 4th ed., 7.2;
OpenCV ``cv2.cvtColor``. Hue is averaged on the circle (directional statistics,
Mardia & Jupp 2000), its spread given as the circular standard deviation.
:func:`unclipped_mean` undoes what a saturating sensor does to a noisy channel's mean
(the mean of a censored normal distribution: Cohen, *Truncated and Censored Samples*,
1991, ch. 2).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.special import ndtr

from cell.errors import VisionError
from cell.vision._checks import check_choice, check_colour, check_mask, check_range

__all__ = ["ColourStats", "colour_stats", "convert_colour", "unclipped_mean"]

ORDERS = ("rgb", "bgr")
SPACES = ("hsv", "lab")


def convert_colour(image: np.ndarray, *, to: str, order: str = "rgb") -> np.ndarray:
    """Convert a uint8 colour image to float32 HSV or Lab (units in the module doc).

    Parameters
    ----------
    image : uint8 (H, W, 3) in ``order`` channel order ("rgb" as the simulator
        renders, "bgr" as ``cv2.imread`` loads).
    to : "hsv" or "lab".

    Returns float32 (H, W, 3): (H deg, S, V) or (L*, a*, b*).
    """
    image = check_colour("image", image)
    check_choice("to", to, SPACES)
    check_choice("order", order, ORDERS)
    f = image.astype(np.float32) / 255.0
    if to == "hsv":
        code = cv2.COLOR_RGB2HSV if order == "rgb" else cv2.COLOR_BGR2HSV
    else:
        code = cv2.COLOR_RGB2Lab if order == "rgb" else cv2.COLOR_BGR2Lab
    return cv2.cvtColor(f, code)


@dataclass(frozen=True)
class ColourStats:
    """Colour statistics of the pixels of one region.

    ``hue_mean`` (degrees, circular mean; NaN when the region has no saturation at
    all) and ``hue_std`` (degrees, circular std, weighted by saturation so grey
    pixels, whose hue is arbitrary, do not count); ``sat_*`` and ``val_*`` in
    [0, 1]; ``lab_mean``/``lab_std`` = (L*, a*, b*); ``chroma_mean`` = mean of
    sqrt(a*^2 + b*^2); ``highlight_fraction``: share of pixels with V >=
    ``highlight_v`` and S <= ``highlight_s`` (specular highlights: bright and
    colourless); ``count``: pixels.
    """

    count: int
    hue_mean: float
    hue_std: float
    sat_mean: float
    sat_std: float
    sat_p90: float
    val_mean: float
    val_std: float
    lab_mean: tuple[float, float, float]
    lab_std: tuple[float, float, float]
    chroma_mean: float
    highlight_fraction: float


def colour_stats(
    image: np.ndarray,
    mask: np.ndarray,
    *,
    order: str = "rgb",
    highlight_v: float = 0.95,
    highlight_s: float = 0.15,
) -> ColourStats:
    """HSV and Lab statistics of the pixels of ``image`` where ``mask`` is set.

    Parameters
    ----------
    image : uint8 (H, W, 3) in ``order`` ("rgb" or "bgr").
    mask : bool or uint8 (H, W), same height and width; must select >= 1 pixel.
    highlight_v, highlight_s : limits, each in [0, 1], defining a specular-highlight
        pixel.

    Only the pixels under the mask are converted, so the cost is proportional to
    the region's area.
    """
    image = check_colour("image", image)
    m = check_mask("mask", mask)
    check_choice("order", order, ORDERS)
    highlight_v = check_range("highlight_v", highlight_v, 0.0, 1.0)
    highlight_s = check_range("highlight_s", highlight_s, 0.0, 1.0)
    if m.shape != image.shape[:2]:
        raise VisionError(
            f"argument 'mask': shape {m.shape} does not match the image's {image.shape[:2]}"
        )
    px = image[m]
    if len(px) == 0:
        raise VisionError("argument 'mask': selects no pixel")
    strip = px.reshape(1, -1, 3)
    hsv = convert_colour(strip, to="hsv", order=order)[0]
    lab = convert_colour(strip, to="lab", order=order)[0]
    h, s, v = hsv[:, 0].astype(np.float64), hsv[:, 1].astype(np.float64), hsv[:, 2]
    ang = np.radians(h)
    wsum = s.sum()
    if wsum > 0:
        c, sn = (s * np.cos(ang)).sum() / wsum, (s * np.sin(ang)).sum() / wsum
        r = float(np.hypot(c, sn))
        hue_mean = float(np.degrees(np.arctan2(sn, c)) % 360.0)
        hue_std = float(np.degrees(np.sqrt(-2.0 * np.log(max(r, 1e-12)))))
    else:
        hue_mean, hue_std = float("nan"), float("nan")
    highlight = (v >= highlight_v) & (s <= highlight_s)
    return ColourStats(
        count=int(len(px)),
        hue_mean=hue_mean,
        hue_std=hue_std,
        sat_mean=float(s.mean()),
        sat_std=float(s.std()),
        sat_p90=float(np.percentile(s, 90)),
        val_mean=float(v.mean()),
        val_std=float(v.std()),
        lab_mean=tuple(float(x) for x in lab.mean(axis=0)),
        lab_std=tuple(float(x) for x in lab.std(axis=0)),
        chroma_mean=float(np.hypot(lab[:, 1], lab[:, 2]).mean()),
        highlight_fraction=float(highlight.mean()),
    )


_MU_GRID = np.linspace(0.0, 255.0, 2041)  # grey levels: the means unclipped_mean tells apart


def unclipped_mean(mean: np.ndarray, *, sigma: float) -> np.ndarray:
    """The mean grey level of a channel before Gaussian read noise was added and the sum
    saturated to 0..255: the ``mu`` in [0, 255] whose N(mu, sigma^2), clipped to
    [0, 255], averages ``mean``. A dark or a bright channel loses part of its noise at an
    end, so its mean drifts toward mid-grey: with sigma = 75, yellow plastic's blue of 19
    reads 40 and a blue belt's red of 59 reads 68, which makes yellow plastic look like
    brass; this takes them back.

    The clipped mean, ``mu (Phi(b) - Phi(a)) + 255 (1 - Phi(b)) + sigma (phi(a) - phi(b))``
    with ``a = -mu / sigma`` and ``b = (255 - mu) / sigma`` (Cohen, *Truncated and
    Censored Samples*, 1991, ch. 2; Phi and phi the standard normal's distribution and
    density), rises with ``mu``; it is inverted by ``np.interp`` on 2,041 values of ``mu``
    (within 0.01 grey levels). A mean beyond what any ``mu`` in [0, 255] gives is taken
    to the nearer end (a specular highlight saturated by the light, not the noise, stays
    255).

    Parameters
    ----------
    mean : finite grey levels in [0, 255], any shape (a channel's mean, or several).
    sigma : the noise's standard deviation (grey levels, 0 to 255); 0 gives ``mean`` back.

    Returns float64 of ``mean``'s shape, in [0, 255]. (The median of a clipped channel
    needs no such correction: clipping keeps the middle value where it is.)
    """
    sigma = check_range("sigma", sigma, 0.0, 255.0)
    try:
        m = np.asarray(mean, dtype=np.float64)
    except (TypeError, ValueError):
        m = np.full(1, np.nan)
    if not (np.isfinite(m).all() and (m.size == 0 or 0.0 <= m.min() <= m.max() <= 255.0)):
        raise VisionError(f"argument 'mean': expected grey levels in [0, 255], got {mean!r}")
    if not ((m < 8 * sigma) | (m > 255 - 8 * sigma)).any():
        return m.copy()  # 8 sigma from both ends: the drift is below 1e-14 grey levels
    a, b = -_MU_GRID / sigma, (255.0 - _MU_GRID) / sigma
    density = (np.exp(-a * a / 2) - np.exp(-b * b / 2)) / np.sqrt(2 * np.pi)
    clipped = _MU_GRID * (ndtr(b) - ndtr(a)) + 255.0 * ndtr(-b) + sigma * density
    return np.interp(m, clipped, _MU_GRID)
