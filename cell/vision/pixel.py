"""Point (pixel) operations: each output pixel depends on the input pixel alone.

Reference: Gonzalez & Woods, *Digital Image Processing*, 4th ed., sections 2.4
(sampling and quantization) and 3.2 (intensity transformations: the negative).
"""

from __future__ import annotations

import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_image, check_int

__all__ = ["invert", "quantize"]


def invert(image: np.ndarray) -> np.ndarray:
    """The negative of an 8-bit image: ``255 - P`` for every pixel (0 -> 255, 200 -> 55).

    Parameters
    ----------
    image : uint8 (H, W) or (H, W, 3).

    Returns a new uint8 array of the same shape. Reference: Gonzalez & Woods 3.2
    (image negatives); OpenCV ``cv2.bitwise_not`` computes the same for uint8.
    """
    image = check_image("image", image)
    return np.subtract(255, image, dtype=np.uint8)


def quantize(image: np.ndarray, *, bits: int, centre: bool = False) -> np.ndarray:
    """Re-quantize an 8-bit image to ``bits`` bits (2**bits grey levels per channel).

    Each pixel keeps its ``bits`` most significant bits; the levels are spaced
    ``2**(8 - bits)`` apart. With ``centre=False`` a pixel maps to the bottom of its
    bin (``(P >> s) << s``, as a ``bits``-bit ADC would store it, scaled back to
    0..255); with ``centre=True`` to the middle of its bin, which halves the mean
    quantization error.

    Parameters
    ----------
    image : uint8 (H, W) or (H, W, 3).
    bits : integer 1..8; 8 returns a copy.
    centre : bool.

    Reference: Gonzalez & Woods 2.4 (intensity quantization, false contouring).
    """
    image = check_image("image", image)
    shift = 8 - check_int("bits", bits, 1, 8)
    if not isinstance(centre, bool | np.bool_):
        raise VisionError(f"argument 'centre': expected True or False, got {centre!r}")
    out = (image >> shift) << shift
    if centre and shift > 0:
        out = out + np.uint8(1 << (shift - 1))
    return out.astype(np.uint8, copy=False)
