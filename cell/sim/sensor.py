"""The camera's sensor model: lens distortion, read noise, bit depth, dead/hot pixels.

The renderer draws an ideal pinhole image; ``SensorModel`` turns it into what a real
camera would deliver, in this order: Brown-Conrady lens distortion (k1, k2, p1, p2, k3,
as OpenCV models it), Gaussian read noise scaled by the sensor gain, quantisation to
``bits`` per channel, then salt-and-pepper pixels. Depth and segmentation go through the
same distortion (nearest neighbour) so every channel stays aligned. All randomness comes
from the ``np.random.Generator`` passed to ``apply`` (no global generator, no OpenCV RNG).

Why a noise bank
----------------
A 640x480 RGB frame needs 921,600 Gaussian values. Drawing them fresh costs about 2 ms
with OpenCV's generator and more with numpy's, several times the whole render on a GPU
(0.5 ms). So the first noisy frame draws a *bank* of ``BANK_FRAMES`` (4) frames' worth
of standard normal values from the generator passed to ``apply``, stored as int16 in
units of 1 / ``BANK_SCALE`` (1/4096 of a standard deviation, clipped at +-8: half the
memory traffic of float32, which is what a frame's cost is made of). Every frame then
takes one contiguous run of H*W*3 values from the bank, starting at a random offset and
with a random sign (both drawn from the same generator), scales it by
``sigma = noise_std * gain`` and adds it to the image in a single ``cv2.addWeighted``
(rounds to the nearest grey level, saturates to 0..255): about 0.3 ms with the image in
the CPU's cache, 0.5 ms on a freshly rendered frame (2-core CPU). The gain may change
from frame to frame (lighting presets): the bank holds unit noise and only the scale
changes.

What the bank keeps and what it gives up (checked in tests/sim/test_sensor.py):

- Each pixel-channel gets N(0, sigma^2) before rounding: the bank's values are
  independent standard normal draws (to 1/4096 sigma; beyond 8 sigma, probability 1e-15,
  they are clipped), and a sign flip keeps them so.
- Within a frame there is no repetition at all: a frame is one run of distinct,
  independent bank values (a run never wraps around the end of the bank), so neighbouring
  pixels and channels are uncorrelated.
- At the same pixel, two frames get different bank values unless their offsets are equal
  (probability 1 / (3 * H*W*3 + 1), about 4e-7 per pair at 640x480, when the two noises
  are equal or opposite): the correlation between two frames' noise is about 0
  (|r| ~ 1e-3), and averaging N frames divides the noise by sqrt(N) as with fresh draws.
- What is given up: two frames whose offsets differ by d < H*W*3 share H*W*3 - d values,
  the second being the first shifted by d values (d // 3 pixels along the rows, the
  channels rotated by d % 3), possibly negated. About 5/9 of all frame pairs overlap in
  this way (0.557 in 200,000 simulated pairs); about 0.13 % of pairs are shifted by less
  than one image row (1,920 values). Only a search
  for a shifted copy of the noise between two frames (e.g. phase correlation of two noisy
  frames of a featureless scene) can notice this; per-frame statistics, same-pixel
  comparisons and frame averaging cannot.
- Cost: the bank is drawn once per ``SensorModel`` (per camera): 7.4 MB of int16 and
  30-40 ms on the first noisy frame at 640x480 (2-core CPU).
- Determinism: the same generator state before the first ``apply`` and the same calls give
  the same images on one machine (OpenCV's float arithmetic may round a value that lands
  exactly between two grey levels differently on another CPU).

Salt and pepper: the number of hit pixels is drawn as Binomial(H*W, fraction) and the
pixels themselves without replacement, each white or black with probability 1/2: the same
distribution as an independent coin per pixel, without drawing H*W random numbers.
Bit depth: ``x & mask`` keeps the top ``bits`` bits, the same as ``(x // step) * step``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from cell.errors import SimError

__all__ = ["BANK_FRAMES", "BANK_SCALE", "SensorModel", "add_noise", "draw_noise_bank",
           "noise_run", "quantise", "salt_and_pepper"]

BANK_FRAMES = 4  # frames' worth of unit noise values in a bank (see the module docstring)
BANK_SCALE = 4096  # a bank value v stands for the unit normal value v / BANK_SCALE


def draw_noise_bank(values_per_frame: int, rng: np.random.Generator, *,
                    frames: int = BANK_FRAMES) -> np.ndarray:
    """A bank of ``frames * values_per_frame`` standard normal values, int16 1-D.

    Values are in units of 1 / ``BANK_SCALE``, rounded, clipped to +-32767 (+-8.0).
    """
    z = rng.standard_normal(frames * values_per_frame, dtype=np.float32)
    z *= BANK_SCALE
    np.rint(z, out=z)
    np.clip(z, -32767, 32767, out=z)
    return z.astype(np.int16)


def noise_run(bank: np.ndarray, values: int, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """One frame's unit noise from ``bank``: ``(run, sign)``.

    ``run`` is a view of ``values`` consecutive bank values (1-D, the bank's dtype)
    starting at an offset drawn uniformly from 0..len(bank) - values; ``sign`` is +1.0 or
    -1.0 with probability 1/2. The frame's unit noise is ``sign * run / BANK_SCALE``.
    """
    if not 0 < values <= bank.size:
        raise SimError(f"noise_run: a frame needs {values} noise values, the bank holds {bank.size}")
    offset = int(rng.integers(0, bank.size - values + 1))
    sign = 1.0 if rng.integers(2) else -1.0
    return bank[offset:offset + values], sign


def _check_uint8(where: str, image: object) -> None:
    """A ``SimError`` naming ``where`` unless ``image`` is a non-empty uint8 array."""
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.size == 0:
        got = f"{image.dtype} {image.shape}" if isinstance(image, np.ndarray) else type(image).__name__
        raise SimError(f"{where}: expected a uint8 image, got {got}")


def add_noise(image: np.ndarray, bank: np.ndarray, sigma: float,
              rng: np.random.Generator) -> np.ndarray:
    """``image`` (uint8, any shape) plus N(0, sigma^2) noise per value, rounded, saturated.

    The noise is ``sign * run / BANK_SCALE`` (``noise_run`` of an int16 bank from
    ``draw_noise_bank``) times ``sigma`` (grey levels). Returns a new uint8 array of
    ``image``'s shape.
    """
    _check_uint8("add_noise", image)
    rows = image.reshape(image.shape[0], -1)  # 2-D, one channel: the bank run lines up
    run, sign = noise_run(bank, rows.size, rng)
    noisy = cv2.addWeighted(rows, 1.0, run.reshape(rows.shape), sign * sigma / BANK_SCALE, 0.0,
                            dtype=cv2.CV_8U)
    return noisy.reshape(image.shape)


def quantise(image: np.ndarray, bits: int) -> None:
    """Keep the top ``bits`` (1..8) bits of each uint8 value of ``image``, in place."""
    _check_uint8("quantise", image)
    if isinstance(bits, bool) or not isinstance(bits, int | np.integer) or not 1 <= bits <= 8:
        raise SimError(f"quantise: bits must be an integer 1 to 8, got {bits!r}")
    if bits < 8:
        np.bitwise_and(image, np.uint8((0xFF << (8 - bits)) & 0xFF), out=image)


def salt_and_pepper(image: np.ndarray, fraction: float, rng: np.random.Generator) -> None:
    """Set a ``fraction`` of the pixels of uint8 (H, W, C) ``image`` to 0 or 255, in place.

    Each pixel is hit with probability ``fraction`` (0..1), independently; a hit pixel
    is white (255 in every channel) or black (0) with probability 1/2.
    """
    _check_uint8("salt_and_pepper", image)
    if not 0.0 <= fraction <= 1.0:  # (NaN fails too)
        raise SimError(f"salt_and_pepper: fraction must be 0 to 1, got {fraction}")
    if image.ndim != 3 or not image.flags.c_contiguous:
        raise SimError("salt_and_pepper: works in place on a C-contiguous (H, W, C) image, got "
                       f"shape {image.shape}")
    pixels = image.reshape(-1, image.shape[-1])  # a view: (H*W, C)
    hits = int(rng.binomial(len(pixels), fraction))
    where = rng.choice(len(pixels), size=hits, replace=False, shuffle=False)
    white = rng.integers(0, 2, size=hits, dtype=np.uint8) * np.uint8(255)
    pixels[where] = white[:, None]


@dataclass
class SensorModel:
    """Sensor parameters: noise in grey levels, s&p fraction, distortion, bits, gain.

    ``K`` the 3x3 camera matrix (pixels), ``width`` x ``height`` the image size,
    ``noise_std`` the read noise's standard deviation at gain 1 (grey levels),
    ``salt_pepper`` the fraction of pixels set to 0 or 255, ``distortion`` (k1, k2, p1,
    p2, k3) and ``bits`` per channel (1..8).
    """

    K: np.ndarray
    width: int
    height: int
    noise_std: float = 0.0
    salt_pepper: float = 0.0
    distortion: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)
    bits: int = 8
    _maps: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False, compare=False)
    _pad: tuple[int, int] = field(default=(0, 0), repr=False, compare=False)
    _bank: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def distorts(self) -> bool:
        return any(abs(c) > 0 for c in self.distortion)

    def _ideal_positions(self) -> np.ndarray:
        """For each pixel (v, u) of the distorted image, float64 (H, W, 2), the position (x,
        y) in the ideal pinhole image (same K) that it sees: its undistorted point
        (``cv2.undistortPointsIter``) projected back through K. A model that folds the image
        (a barrel lens turning back before the corners) has no such position for some
        pixels (the undistortion stops anywhere): a ``SimError`` naming the first."""
        u, v = np.meshgrid(np.arange(self.width), np.arange(self.height))
        pts = np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64)[:, None, :]
        dist = np.asarray(self.distortion, np.float64)
        # (40 iterations stopped px short near the edges of strong, unfolded lenses)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
        ideal = cv2.undistortPointsIter(pts, self.K, dist, None, self.K, criteria).reshape(-1, 2)
        from cell.camera import CameraModel
        from cell.vision.geometry import no_ray  # (the detector's own test of a ray)

        lens = CameraModel(self.width, self.height, self.K, dist, np.eye(4))
        with np.errstate(invalid="ignore", over="ignore"):
            normalised = (ideal - self.K[:2, 2]) / np.diag(self.K)[:2]
        lost = no_ray(lens, normalised, pts.reshape(-1, 2))
        if lost.any():
            x, y = pts.reshape(-1, 2)[int(np.argmax(lost))]
            raise SimError(f"sensor.distortion {list(self.distortion)}: the lens model folds the "
                           f"image (pixel ({x:g}, {y:g}) and {int(lost.sum()) - 1} more see no "
                           "ray of it): weaker coefficients, or a narrower camera.fovy")
        return ideal.reshape(self.height, self.width, 2)

    def padding(self) -> tuple[int, int]:
        """(x, y) pixels by which the ideal render reaches beyond the image on each side, so
        that every distorted pixel samples what the lens sees there: a barrel lens sees
        more than the pinhole view near the corners ([-0.2, 0.05, 0, 0, 0] at 40 degrees
        reaches 27 px beyond it; the edge pixels were repeated over 9 % of the image). (0, 0)
        without distortion; a ``SimError`` when the render would have to be over twice the
        image's size."""
        if not self.distorts:
            return (0, 0)
        if self._maps is None:
            ideal = self._ideal_positions()
            x, y = ideal[..., 0], ideal[..., 1]
            pad = (math.ceil(max(0.0, -x.min(), x.max() - (self.width - 1))) + 1,
                   math.ceil(max(0.0, -y.min(), y.max() - (self.height - 1))) + 1)
            if pad[0] > self.width // 2 or pad[1] > self.height // 2:
                raise SimError(f"sensor.distortion {list(self.distortion)}: the lens sees "
                               f"{pad[0]} x {pad[1]} px beyond the pinhole view on each side, "
                               "more than half the image: weaker coefficients, or a narrower "
                               "camera.fovy")
            self._maps = ((x + pad[0]).astype(np.float32), (y + pad[1]).astype(np.float32))
            self._pad = pad
        return self._pad

    def _distortion_maps(self) -> tuple[np.ndarray, np.ndarray]:
        """For each pixel of the distorted image, where to sample the ideal render, which
        reaches :meth:`padding` beyond the image on each side."""
        self.padding()
        return self._maps

    def warp(self, image: np.ndarray, *, nearest: bool = False) -> np.ndarray:
        """Apply the lens distortion to an ideal render (any dtype cv2.remap takes) of the
        image's size plus :meth:`padding` on each side; the image's size out.

        Returns ``image`` itself when there is no distortion.
        """
        if not self.distorts:
            return image
        mx, my = self._distortion_maps()
        px, py = self._pad
        if image.shape[:2] != (self.height + 2 * py, self.width + 2 * px):
            raise SimError(f"sensor: expected an ideal render of {self.width + 2 * px} x "
                           f"{self.height + 2 * py} px (the image and the lens' padding), got "
                           f"{image.shape[1]} x {image.shape[0]}")
        interp = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
        return cv2.remap(image, mx, my, interp, borderMode=cv2.BORDER_REPLICATE)

    def noise_bank(self, rng: np.random.Generator) -> np.ndarray:
        """This sensor's bank of unit noise (int16 1-D), drawn from ``rng`` on first use."""
        if self._bank is None:
            self._bank = draw_noise_bank(self.height * self.width * 3, rng)
        return self._bank

    def apply(self, rgb: np.ndarray, rng: np.random.Generator, *, gain: float = 1.0) -> np.ndarray:
        """The delivered image, uint8 (H, W, 3), from an ideal uint8 render (H, W, 3; with
        distortion, :meth:`padding` larger on each side).

        ``gain`` (>= 0) multiplies the read noise. ``rgb`` is never modified; it is
        returned itself when the model changes nothing (no distortion, noise, s&p, bits 8).
        """
        px, py = self.padding()
        shape = (self.height + 2 * py, self.width + 2 * px, 3)
        if rgb.dtype != np.uint8 or rgb.shape != shape:
            raise SimError(f"sensor: expected a uint8 {shape} image, got {rgb.dtype} {rgb.shape}")
        if not (math.isfinite(gain) and gain >= 0):
            raise SimError(f"sensor: gain must be finite and >= 0, got {gain}")
        out = self.warp(rgb)
        sigma = self.noise_std * gain
        if sigma > 0:
            out = add_noise(out, self.noise_bank(rng), sigma, rng)
        elif out is rgb and (self.bits < 8 or self.salt_pepper > 0):
            out = rgb.copy()  # the steps below work in place
        quantise(out, self.bits)
        if self.salt_pepper > 0:
            salt_and_pepper(out, self.salt_pepper, rng)
        return out
