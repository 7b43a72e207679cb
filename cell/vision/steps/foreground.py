"""Step 1, foreground: which pixels are not the belt.

A frame with impulse noise (salt and pepper: dead and hot pixels, black or white alone
among their neighbours, :func:`impulse_share`) over 4 % of its pixels is replaced by its
3x3 median first (unless ``smooth`` is 0: no smoothing of any kind), the textbook cure
(Gonzalez & Woods, *Digital Image Processing*, 5.3): the steps after it read the median.
Below that the belt model's medians and the opening already ignore the specks, and a
median would cost the outlines some precision.

``segmentation = "belt"`` (the default) learns the empty belt from the frame itself: a
15-wide median over a 1/8-scale copy (120 px at full scale: 73 mm of the table seen by the
default camera, wider than any part) keeps the belt, its texture's mean, light gradients
and spot lights, and drops the parts. A camera that sees the table finer (more pixels, a
narrower field of view: ``m_per_px``) gets a coarser copy, so that the median stays at
least 72 mm wide on the table (1/16 at 1280x960, 1/13 at 1000x750): else a large part
fills half its window and becomes belt, its middle lost. The
difference image is the largest channel difference from that belt (grey levels), so a
red part on a blue belt differs as much as a bright one on a dark belt. It is
thresholded at the frame's own noise level (median + ``noise_k`` sigma of the
difference, sigma = 1.4826 x its MAD, at least ``belt_floor``, and at least 1.5 of the
grey steps a sensor of 3 to 7 bits leaves, :func:`grey_step`: under a light that falls
off, such a belt is bands of flat colour a step apart, and no noise is left to measure;
a coarser step is as large as a part's contrast); the outline step then re-thresholds
each blob in its own box. A noisy frame (that sigma over 2 grey levels) is smoothed by a
Gaussian first, 3x3 (``smooth``) or wider where the sensor's noise
(:func:`noise_sigma`) asks for it: the smallest aperture up to 15 that leaves under 8.5
grey levels of that noise (7x7 at 40 grey levels, 13x13 at 60). It is thresholded with
hysteresis: its threshold stands high over a faint part's contrast, so a pixel above
``belt_low`` times the threshold is foreground too where it connects to one above it,
and a faint part that is clear somewhere is one group of pixels, not fragments (Canny,
1986, applied to regions). A bright, colourless belt is a light table (``backlit``).

The textbook methods threshold the grey image instead, with the syllabus functions of
:mod:`cell.vision.threshold`: ``fixed`` (``threshold``), ``otsu``, ``iterative``
(Ridler-Calvard) and ``adaptive`` (local mean); parts are brighter than the dark belt,
darker than a light table. Either way an opening (3x3) removes specks.

References: background subtraction with a median background model (Piccardi, *Background
subtraction techniques: a review*, 2004); MAD as a robust noise scale (Hampel, 1974).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_colour, check_image, check_range
from cell.vision.morphology import opening
from cell.vision.settings import VisionSettings
from cell.vision.threshold import (
    threshold_adaptive,
    threshold_fixed,
    threshold_hysteresis,
    threshold_iterative,
    threshold_otsu,
)

__all__ = ["BeltModel", "Foreground", "belt_model", "belt_scale", "colour_difference",
           "find_foreground", "grey_step", "impulse_share", "noise_sigma"]

_SCALE = 8  # the belt model's downscale factor, at least
_MEDIAN = 15  # small pixels: the belt median's width
_WINDOW = 0.072  # m: the belt median's least width on the table (73 mm: the default camera's)
_THREE = np.ones((1, 3), np.uint8)
_NOISY = 2.0  # grey levels: a frame noisier than this is smoothed for the outlines
_IMPULSES = 0.04  # a frame with more impulse noise than this share of pixels is despeckled
_STEPS = 1.5  # grey steps of the frame's quantisation the threshold stands at, at least,
_WIDEST_BANDS = 32  # for steps up to this (3 bits); a coarser step is a part's contrast
_SMOOTHED = 8.5  # grey levels of noise the smoothing leaves at most, where it can
_WIDEST_SMOOTHING = 15  # px: the smoothing's widest aperture


@dataclass(frozen=True)
class BeltModel:
    """The empty belt under this frame's light at 1/``scale`` scale, uint8 RGB each:
    ``median``, and per channel the ``low`` and ``high`` ends of the medians within 2
    small pixels (where the belt meets the table, both). :meth:`at` gives them at any
    scale, :meth:`median_in` the median in a window."""

    median: np.ndarray
    low: np.ndarray
    high: np.ndarray
    scale: int = _SCALE

    def at(self, size: tuple[int, int]) -> BeltModel:
        """The model resized (bilinear) to ``size`` (width, height)."""
        return BeltModel(*(cv2.resize(m, size, interpolation=cv2.INTER_LINEAR)
                           for m in (self.median, self.low, self.high)), scale=1)

    def median_in(self, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
        """The median at full scale in the window [y0:y1, x0:x1] (uint8 RGB): what resizing
        it whole gives there, from the few small pixels around the window only."""
        s = self.scale
        hs, ws = self.median.shape[:2]
        i0, j0 = max(y0 // s - 1, 0), max(x0 // s - 1, 0)
        i1, j1 = min(-(-y1 // s) + 1, hs), min(-(-x1 // s) + 1, ws)
        up = cv2.resize(self.median[i0:i1, j0:j1], ((j1 - j0) * s, (i1 - i0) * s),
                        interpolation=cv2.INTER_LINEAR)
        return up[y0 - i0 * s:y1 - i0 * s, x0 - j0 * s:x1 - j0 * s]


def belt_model(image: np.ndarray, *, scale: int = _SCALE) -> BeltModel:
    """The :class:`BeltModel` of a uint8 RGB frame (H, W, 3): a 15-wide median
    (``cv2.medianBlur``) of every ``scale``-th pixel of every ``scale``-th row (from (0, 0);
    no blend of a part's colour with the belt's), and its 5x5 minimum and maximum."""
    check_colour("image", image)
    if isinstance(scale, bool) or not isinstance(scale, int | np.integer) or not 1 <= scale <= 4096:
        raise VisionError(f"argument 'scale': expected an integer 1 to 4096, got {scale!r}")
    small = np.ascontiguousarray(image[::scale, ::scale])
    med = cv2.medianBlur(small, _MEDIAN)
    square = np.ones((5, 5), np.uint8)
    return BeltModel(med, cv2.erode(med, square), cv2.dilate(med, square), int(scale))


def belt_scale(m_per_px: float | None) -> int:
    """The belt model's downscale factor for pixels of ``m_per_px`` metres on the table:
    the median at least ``_WINDOW`` wide there, the factor at least 8 (None: 8)."""
    if m_per_px is None:
        return _SCALE
    m_per_px = check_range("m_per_px", m_per_px, 1e-9, 1.0)
    return max(_SCALE, min(math.ceil(_WINDOW / (_MEDIAN * m_per_px)), 4096))


def colour_difference(image: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """How far each pixel's colour lies outside the belt's nearby range ``low``..``high``
    (uint8 RGB, the image's shape): the largest over the channels of (image - high) or
    (low - image), 0 inside (uint8 (H, W)). A pixel where the belt meets the table matches
    one of them: no false edge there."""
    for name, value in (("image", image), ("low", low), ("high", high)):
        check_colour(name, value)
    if not image.shape == low.shape == high.shape:
        raise VisionError(f"colour_difference: image, low and high must have one shape, got "
                          f"{image.shape}, {low.shape}, {high.shape}")
    out = cv2.max(cv2.subtract(image, high), cv2.subtract(low, image))
    h, w = out.shape[:2]
    # the largest channel: a 1x3 dilation of the interleaved rows, read at the middle channel
    return np.ascontiguousarray(cv2.dilate(out.reshape(h, 3 * w), _THREE)[:, 1::3])


@dataclass(frozen=True)
class Foreground:
    """The foreground of one frame.

    ``mask`` uint8 (H, W), 255 on the foreground; ``difference`` uint8 (H, W), the colour
    difference from the belt (grey levels; the grey image itself for the textbook
    methods); ``belt`` the :class:`BeltModel`; ``threshold`` the grey level that
    separated them; ``backlit`` whether the belt is a light table; ``image`` the frame
    the difference was taken of (smoothed when noisy); ``noise`` the colour difference's
    spread before any smoothing (a Gaussian sigma from its MAD, grey levels: sensor noise
    and belt texture); ``impulses`` the share of its pixels that are impulse noise
    (:func:`impulse_share`): over 4 %, every image above is of the frame's 3x3 median.
    """

    mask: np.ndarray
    difference: np.ndarray
    belt: BeltModel
    threshold: float
    backlit: bool
    image: np.ndarray
    noise: float
    impulses: float


def noise_sigma(image: np.ndarray) -> float:
    """The frame's sensor noise (grey levels): the differences d of the green channel's
    pixels two apart (x = 2, 4, ... minus x - 2) on every 16th row from row 4; the MAD
    (element n // 2 in order of |d - m|, m element n // 2 of d: upper medians), times
    1.4826 / sqrt(2). Robust: edges and grain, a minority, do not count. 0 when the frame
    has no such pairs (fewer than 5 rows or 3 columns). ``image`` uint8 RGB (H, W, 3)."""
    check_colour("image", image)
    d = np.diff(image[4::16, ::2, 1].astype(np.int16), axis=1).reshape(-1)
    if d.size == 0:
        return 0.0
    k = d.size // 2
    dev = np.abs(d - np.partition(d, k)[k])
    return 1.4826 * float(np.partition(dev, k)[k]) / math.sqrt(2)


def _smoothing_aperture(noise: float, *, least: int, sigma: float = 0.0) -> int:
    """The aperture (px, odd) of the Gaussian that smooths a frame of sensor noise
    ``noise`` (grey levels): the smallest from ``least`` up to 15 that leaves under
    ``_SMOOTHED`` grey levels of it (the noise times the root of the 2-D kernel's sum of
    squares, ``cv2.getGaussianKernel(k, sigma)``; ``sigma`` 0: from the aperture), else 15.
    At the default 3: 3 to a noise of 22 grey levels, 7 at 40, 13 at 60, 15 from 75."""
    for k in range(least, _WIDEST_SMOOTHING + 1, 2):
        if noise * float(np.sum(cv2.getGaussianKernel(k, sigma) ** 2)) <= _SMOOTHED:
            return k
    return max(least, _WIDEST_SMOOTHING)


def impulse_share(image: np.ndarray) -> float:
    """The share of a uint8 RGB frame's (H, W, 3) pixels that are impulse noise (salt and
    pepper: dead or hot pixels): black (0) or white (255) in every channel while neither
    neighbour on its row is, counted on every 8th row from row 4 (0 for a frame narrower
    than 3 pixels or shorter than 5 rows). A glare spot's saturated pixels come in groups
    and do not count; dense impulses neither (it reads 0.16 for 20 %), and Gaussian noise
    that clips a dark belt to black gives a few (0.5 % at a sigma of 90 grey levels)."""
    check_colour("image", image)
    rows = image[4::8]
    if rows.shape[0] == 0 or rows.shape[1] < 3:
        return 0.0
    isolated = 0
    for level in (0, 255):
        at = cv2.inRange(rows, (level,) * 3, (level,) * 3)  # 255 where every channel is level
        isolated += cv2.countNonZero(at[:, 1:-1] & ~at[:, :-2] & ~at[:, 2:])
    return isolated / (rows.shape[0] * (rows.shape[1] - 2))


def grey_step(image: np.ndarray) -> int:
    """The spacing of the grey levels a uint8 frame, (H, W) or (H, W, 3), uses: 2 ** (8 - bits) for
    a sensor that keeps its top ``bits`` (1 for 8 bits): the largest power of two (up to
    128) that divides all but 1 % of the values of every 8th row from row 4 (impulse noise's
    white, 255, divides by none). 1 for a frame of under 5 rows."""
    check_image("image", image)
    rows = image[4::8]
    if rows.size == 0:
        return 1
    values = rows.reshape(len(rows), -1)  # 2-D: OpenCV counts a 1-D array row by row, slowly
    for k in range(7, 0, -1):
        if cv2.countNonZero(values & np.uint8((1 << k) - 1)) <= 0.01 * values.size:
            return 1 << k
    return 1


def _median_mad(values: np.ndarray) -> tuple[float, float]:
    """Median and MAD (scaled to a Gaussian sigma) of every 4th pixel of every 4th row."""
    sample = values[::4, ::4].ravel()
    med = float(np.median(sample))
    return med, 1.4826 * float(np.median(np.abs(sample - med)))


def _is_backlit(belt: np.ndarray, level: int) -> bool:
    """A bright (median of the brightest channel >= ``level``), colourless belt."""
    sample = belt[::3, ::3].reshape(-1, 3).astype(np.int16)
    return (float(np.median(sample.max(axis=1))) >= level
            and float(np.median(np.ptp(sample, axis=1))) < 40)


def find_foreground(image: np.ndarray, settings: VisionSettings, *,
                    m_per_px: float | None = None) -> Foreground:
    """The :class:`Foreground` of a uint8 RGB frame (H, W, 3) by ``settings.segmentation``
    (see the module docstring); ``m_per_px`` (metres on the table per pixel, None: the
    default camera's) sizes the belt model (:func:`belt_scale`)."""
    check_colour("image", image)
    if not isinstance(settings, VisionSettings):
        raise VisionError(f"argument 'settings': expected VisionSettings, got {type(settings).__name__}")
    st = settings
    h, w = image.shape[:2]
    impulses = impulse_share(image)
    if st.smooth and impulses > _IMPULSES:  # salt and pepper: the textbook cure, a median
        image = cv2.medianBlur(image, 3)
    belt = belt_model(image, scale=belt_scale(m_per_px))
    backlit = _is_backlit(belt.median, st.backlight_level)
    low, high = (cv2.resize(m, (w, h), interpolation=cv2.INTER_LINEAR) for m in (belt.low, belt.high))
    diff = colour_difference(image, low, high)
    med, mad = _median_mad(diff)
    noise, smoothed = mad, image
    if st.smooth and noise > _NOISY:  # sensor noise: average first
        k = _smoothing_aperture(noise_sigma(image), least=st.smooth, sigma=st.smooth_sigma)
        smoothed = cv2.GaussianBlur(image, (k, k), st.smooth_sigma)
    if st.segmentation == "belt":
        if smoothed is not image:
            diff = colour_difference(smoothed, low, high)
            med, mad = _median_mad(diff)
        step = grey_step(image)
        bands = _STEPS * step if step <= _WIDEST_BANDS else 0.0  # (quantisation's bands)
        floor = max(float(st.belt_floor), bands)
        t = min(max(floor, med + st.noise_k * max(mad, 0.5)), 255.0)
        if noise > _NOISY:  # the threshold stands high over faint parts: hysteresis
            mask = threshold_hysteresis(diff, low=st.belt_low * t, high=t)
        else:
            mask = threshold_fixed(diff, value=t)
    else:
        diff = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        polarity = "dark" if backlit else "bright"
        if st.segmentation == "adaptive":
            t = float(st.adaptive_offset)
            mask = threshold_adaptive(diff, block_size=st.adaptive_block, offset=t,
                                      polarity=polarity)
        else:
            t = {"fixed": lambda: float(st.threshold), "otsu": lambda: float(threshold_otsu(diff)),
                 "iterative": lambda: float(threshold_iterative(diff))}[st.segmentation]()
            mask = threshold_fixed(diff, value=t, polarity=polarity)
            if st.segmentation != "fixed" and diff.min() == diff.max():
                mask[:] = False  # one grey level: no two classes, whatever the polarity
    mask = opening(mask.view(np.uint8) * np.uint8(255))
    return Foreground(mask, diff, belt, t, backlit, smoothed, noise, impulses)
