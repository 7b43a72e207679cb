"""The camera's sensor model: lens distortion, read noise, bit depth, dead/hot pixels.

The renderer draws an ideal pinhole image; ``SensorModel`` turns it into what a real
camera would deliver, in this order: Brown-Conrady lens distortion (k1, k2, p1, p2, k3,
as OpenCV models it), Gaussian read noise scaled by the sensor gain, quantisation to
``bits`` per channel, then salt-and-pepper pixels. Depth and segmentation go through the
same distortion (nearest neighbour) so every channel stays aligned. Noise comes only from
the ``np.random.Generator`` passed in.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = ["SensorModel"]


def _add_gaussian(image: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``image`` (uint8) plus N(0, sigma^2) noise per pixel and channel, rounded, saturated.

    OpenCV's generator is 3-4x faster than numpy's for a full frame; it is seeded from
    ``rng`` each call, so the run stays a function of the scenario seed alone.
    """
    flat = image.reshape(image.shape[0], -1)  # one channel: randn's sigma is per channel
    noise = np.empty(flat.shape, np.float32)
    cv2.setRNGSeed(int(rng.integers(2**31 - 1)))
    cv2.randn(noise, 0.0, float(sigma))
    return cv2.add(flat.astype(np.float32), noise, dtype=cv2.CV_8U).reshape(image.shape)


@dataclass
class SensorModel:
    """Sensor parameters: noise in grey levels, s&p fraction, distortion, bits, gain."""

    K: np.ndarray
    width: int
    height: int
    noise_std: float = 0.0
    salt_pepper: float = 0.0
    distortion: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)
    bits: int = 8
    _maps: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    @property
    def distorts(self) -> bool:
        return any(abs(c) > 0 for c in self.distortion)

    def _distortion_maps(self) -> tuple[np.ndarray, np.ndarray]:
        """For each pixel of the distorted image, where to sample the ideal one.

        A distorted pixel's ideal position is its undistorted point
        (``cv2.undistortPointsIter``) projected back through K.
        """
        if self._maps is None:
            u, v = np.meshgrid(np.arange(self.width), np.arange(self.height))
            pts = np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64)[:, None, :]
            criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-9)
            ideal = cv2.undistortPointsIter(
                pts, self.K, np.asarray(self.distortion, np.float64), None, self.K, criteria
            ).reshape(self.height, self.width, 2)
            self._maps = (ideal[..., 0].astype(np.float32), ideal[..., 1].astype(np.float32))
        return self._maps

    def warp(self, image: np.ndarray, *, nearest: bool = False) -> np.ndarray:
        """Apply the lens distortion to an ideal image (any dtype cv2.remap takes)."""
        if not self.distorts:
            return image
        mx, my = self._distortion_maps()
        interp = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
        return cv2.remap(image, mx, my, interp, borderMode=cv2.BORDER_REPLICATE)

    def apply(self, rgb: np.ndarray, rng: np.random.Generator, *, gain: float = 1.0) -> np.ndarray:
        """The delivered image from an ideal uint8 (H, W, 3) render."""
        out = self.warp(rgb)
        sigma = self.noise_std * gain
        if sigma > 0:
            out = _add_gaussian(out, sigma, rng)
        if self.bits < 8:
            step = 1 << (8 - self.bits)
            out = (out // step) * step
        if self.salt_pepper > 0:
            hit = rng.random(out.shape[:2]) < self.salt_pepper
            salt = rng.random(out.shape[:2]) < 0.5
            out = out.copy()
            out[hit & salt] = 255
            out[hit & ~salt] = 0
        return out
