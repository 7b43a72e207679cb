"""Colour conversion (HSV, CIE Lab) and colour statistics of a region.

Statistics only: the metal/plastic classifier lives in ``cell.vision.steps.material``.
Conversions run in float32 so the units are the textbook ones: H in degrees
[0, 360), S and V in [0, 1], L* in [0, 100], a* and b* roughly [-127, 127]
(D65 white, sRGB gamma, as ``cv2.cvtColor`` computes for float images).

References: A. R. Smith, "Color gamut transform pairs", SIGGRAPH 1978 (HSV);
CIE 15:2004 (L*a*b*); Gonzalez & Woods, *Digital Image Processing*, 4th ed., 7.2;
OpenCV ``cv2.cvtColor``. Hue is averaged on the circle (directional statistics,
Mardia & Jupp 2000), its spread given as the circular standard deviation.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_choice, check_colour, check_mask, check_range

__all__ = ["ColourStats", "colour_stats", "convert_colour"]

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
