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

from cell.vision._checks import MAX_SIZE, check_finite, check_image, check_int, check_odd, check_range

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
    image : uint8 or float32 (finite), (H, W) or (H, W, 3).
    iterations : number of passes, 0 (returns a copy) to ``4096 // ksize``, so that the
        work (passes x kernel width) stays bounded: 1365 passes of the 3x3 kernel.
    ksize : odd kernel size in pixels, 1 to 4095.
    sigma : Gaussian standard deviation in pixels, 0 to 4095; 0 lets OpenCV derive it
        from ksize.

    Returns an array of the input dtype and shape. Wraps ``cv2.GaussianBlur``
    (border: reflect-101).
    """
    image = check_finite("image", check_image("image", image, dtypes=(np.uint8, np.float32)))
    check_odd("ksize", ksize)
    check_int("iterations", iterations, 0, (MAX_SIZE + 1) // ksize)
    sigma = check_range("sigma", sigma, 0.0, MAX_SIZE)
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
    ksize : odd window size in pixels, 3 to 255 (OpenCV counts the window's pixels in
        16-bit histogram bins: 255 x 255 = 65025 is the largest window that fits).

    Wraps ``cv2.medianBlur``.
    """
    image = check_image("image", image)
    check_odd("ksize", ksize, minimum=3, maximum=255)
    return cv2.medianBlur(np.ascontiguousarray(image), ksize)
