"""Smoothing filters: iterated Gaussian and median.

Reference: Gonzalez & Woods, *Digital Image Processing*, 4th ed., 3.5 (smoothing
spatial filters) and 5.3 (order-statistic filters: the median against salt-and-pepper
noise). The 3x3 Gaussian applied ``n`` times equals one Gaussian of variance ``n``
times larger (the kernels convolve), which is why repeating a small kernel smooths
progressively.
"""

from __future__ import annotations

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_image, check_odd

__all__ = ["gaussian_iterated", "median"]


def gaussian_iterated(
    image: np.ndarray, *, iterations: int = 1, ksize: int = 3, sigma: float = 0.0
) -> np.ndarray:
    """Apply a ``ksize`` x ``ksize`` Gaussian filter ``iterations`` times.

    The passes run in float32 and the result is rounded back once, so repeated
    passes on a uint8 image do not accumulate rounding error. With ``ksize=3`` and
    ``sigma=0`` each pass is the binomial kernel [1 2 1]/4 along each axis
    (variance 0.5 px^2 per pass).

    Parameters
    ----------
    image : uint8 or float32, (H, W) or (H, W, 3).
    iterations : number of passes, >= 0 (0 returns a copy).
    ksize : odd kernel size in pixels.
    sigma : Gaussian standard deviation in pixels; 0 lets OpenCV derive it from ksize.

    Returns an array of the input dtype and shape. Wraps ``cv2.GaussianBlur``
    (border: reflect-101).
    """
    image = check_image("image", image, dtypes=(np.uint8, np.float32))
    check_odd("ksize", ksize)
    if not isinstance(iterations, int | np.integer) or iterations < 0:
        raise VisionError(f"argument 'iterations': expected an integer >= 0, got {iterations!r}")
    out = image.astype(np.float32)
    for _ in range(int(iterations)):
        out = cv2.GaussianBlur(out, (ksize, ksize), sigma)
    if image.dtype == np.uint8:
        return np.clip(np.rint(out), 0, 255).astype(np.uint8)
    return out


def median(image: np.ndarray, *, ksize: int = 3) -> np.ndarray:
    """Median filter: each pixel becomes the median of its ``ksize`` x ``ksize`` window.

    An order-statistic filter: isolated outliers (salt-and-pepper noise) are removed
    outright instead of being smeared into their neighbours as a linear filter does,
    and step edges are preserved.

    Parameters
    ----------
    image : uint8 (H, W) or (H, W, 3).
    ksize : odd window size in pixels, >= 3.

    Wraps ``cv2.medianBlur``.
    """
    image = check_image("image", image)
    check_odd("ksize", ksize, minimum=3)
    return cv2.medianBlur(np.ascontiguousarray(image), ksize)
