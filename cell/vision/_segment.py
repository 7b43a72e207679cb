"""Parts apart from the belt: background estimate, foreground mask, one blob per part.

The background is learned from the frame itself: a median filter much wider than any
part over a 1/8-scale copy (borders mirrored) estimates the empty belt, and whatever else
surrounds it, under the frame's own lighting. The foreground is the largest channel
difference from it at half scale (every other pixel), thresholded (noise-adaptive:
median + k * MAD; fixed; or Otsu) and opened. Each blob is then refined at full scale in
its own box only: the difference there is re-thresholded at a fraction (``edge_level``)
of the blob's own contrast, and shadow pixels (the background darkened without a change
of colour) are dropped, so the outline sits on the part's edge whatever its contrast.
No full-scale operation runs on the whole frame; the boxes are processed all at once,
side by side in one image (:mod:`cell.vision._mosaic`), each as if alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from cell.vision._blob import Blob, blobs_of_windows
from cell.vision._footprint import Geometry
from cell.vision._mosaic import MAX_WINDOWS, Mosaic
from cell.vision.settings import VisionSettings

__all__: list[str] = []  # private to cell.vision

_BG_SCALE = 8  # the background model's downscale factor
_BG_MEDIAN = 15  # its median aperture at that scale (120 px at full scale)
_K2 = np.ones((2, 2), np.uint8)  # an opening at half scale that keeps a 4 px ring
_K3 = np.ones((3, 3), np.uint8)
_K5 = np.ones((5, 5), np.uint8)
_LEVELS = np.arange(256)
_DIFFS = np.arange(511)


@dataclass
class FrameView:
    """One frame as the detector's steps share it.

    ``img`` uint8 RGB (H, W, 3); ``bg_small`` its background estimate at 1/8 scale;
    ``dmax`` uint8 (H/2, W/2) the largest channel difference from it at half scale,
    ``mask`` its foreground (0/255) at ``threshold`` grey levels; ``fg`` uint8 (H, W)
    the full-scale foreground, filled in around each blob as it is refined; ``smooth``
    the box filter applied before differencing (0: none); ``backlit`` whether the
    background is a bright light table; ``max_px``/``min_px`` the longest blob side (px)
    and the smallest blob area (px^2) kept, at full scale.
    """

    img: np.ndarray
    bg_small: np.ndarray
    dmax: np.ndarray
    mask: np.ndarray
    threshold: float
    smooth: int
    backlit: bool
    geo: Geometry
    settings: VisionSettings
    max_px: int
    min_px: float
    fg: np.ndarray | None = None
    _sigma: float | None = None

    def __post_init__(self) -> None:
        if self.fg is None:
            self.fg = np.zeros(self.img.shape[:2], np.uint8)

    def noise_sigma(self) -> float:
        """The frame's sensor noise (grey levels, green channel), from differences of pixels
        two apart on every 16th row: robust (MAD), so edges and grain, a minority, do not
        count. Computed on first use."""
        if self._sigma is None:
            rows = self.img[4::16, ::2, 1].astype(np.int16)
            d = (rows[:, 1:] - rows[:, :-1]).ravel() + 255  # 0..510
            hist = np.bincount(d, minlength=511)
            cum = np.cumsum(hist)
            half = d.size // 2 + 1  # the upper median, as np.partition(d, d.size // 2)
            med = int(np.searchsorted(cum, half))
            dev = np.bincount(np.abs(_DIFFS - med), weights=hist, minlength=511)
            mad = float(np.searchsorted(np.cumsum(dev), half))
            self._sigma = 1.4826 * mad / math.sqrt(2)
        return self._sigma

    def background_at(self, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
        """The background estimate (uint8 RGB) of the window [y0:y1, x0:x1] at full scale:
        what ``cv2.resize`` of the whole 1/8-scale estimate to full scale (bilinear) gives
        there, computed from the few small pixels around the window only."""
        s = _BG_SCALE
        hs, ws = self.bg_small.shape[:2]
        i0, j0 = max(y0 // s - 1, 0), max(x0 // s - 1, 0)
        i1, j1 = min(-(-y1 // s) + 1, hs), min(-(-x1 // s) + 1, ws)
        block = self.bg_small[i0:i1, j0:j1]
        up = cv2.resize(block, ((j1 - j0) * s, (i1 - i0) * s), interpolation=cv2.INTER_LINEAR)
        return up[y0 - i0 * s : y1 - i0 * s, x0 - j0 * s : x1 - j0 * s]


def background(img: np.ndarray, settings: VisionSettings) -> tuple[np.ndarray, bool]:
    """(background estimate at 1/8 scale, uint8 RGB; back-lit?) of a uint8 RGB frame: a
    15-wide median (``cv2.medianBlur``, 120 px at full scale, borders mirrored) over every
    8th pixel. Back-lit when the background's median brightness reaches
    ``settings.backlight_level`` and it is nearly colourless.
    """
    small = _every_8th(img)
    r = _BG_MEDIAN // 2  # mirror the borders, so a window there sees a whole neighbourhood
    padded = cv2.copyMakeBorder(small, r, r, r, r, cv2.BORDER_REFLECT_101)
    bg_small = np.ascontiguousarray(cv2.medianBlur(padded, _BG_MEDIAN)[r:-r, r:-r])
    probe = bg_small[::3, ::3]  # every 24 px; the largest and smallest channel of each
    red, green, blue = probe[..., 0], probe[..., 1], probe[..., 2]
    hi = np.maximum(np.maximum(red, green), blue).ravel()
    lo = np.minimum(np.minimum(red, green), blue).ravel()
    k = hi.size // 2  # upper median (as np.median for odd counts)
    level = float(np.partition(hi, k)[k])
    spread = float(np.partition(hi - lo, k)[k])
    backlit = level >= settings.backlight_level and spread < 40
    return bg_small, backlit


def _every_8th(img: np.ndarray) -> np.ndarray:
    """``img[4::8, 4::8]`` (contiguous): ``cv2.resize`` (nearest, scale exactly 1/8) of the
    image from (4, 4) picks those pixels, several times faster than numpy's strided copy;
    where its rounded size differs from the slice's, the slice itself."""
    o, s = _BG_SCALE // 2, _BG_SCALE
    h, w = img.shape[:2]
    shape = (len(range(o, h, s)), len(range(o, w, s)))
    if min(h, w) >= 2 * s:  # (a smaller crop would round to no pixels)
        small = cv2.resize(img[o:, o:], None, fx=1 / s, fy=1 / s, interpolation=cv2.INTER_NEAREST)
        if small.shape[:2] == shape:
            return small
    return np.ascontiguousarray(img[o::s, o::s])


def _max_channel_diff(img: np.ndarray, bg: np.ndarray) -> np.ndarray:
    red, green, blue = cv2.split(cv2.absdiff(img, bg))
    return cv2.max(cv2.max(red, green), blue)


def _median_mad(dmax: np.ndarray) -> tuple[float, float]:
    """Median and MAD (scaled to a Gaussian sigma) of every 4th pixel, from its histogram."""
    hist = np.bincount(dmax[2::4, 2::4].ravel(), minlength=256)
    cum = np.cumsum(hist)
    med = int(np.searchsorted(cum, (cum[-1] + 1) // 2))
    dev = np.bincount(np.abs(_LEVELS - med), weights=hist, minlength=256)  # of |x - med|
    cdev = np.cumsum(dev)
    mad = int(np.searchsorted(cdev, (cdev[-1] + 1) // 2))
    return float(med), mad * 1.4826


def foreground(
    img: np.ndarray, bg_small: np.ndarray, settings: VisionSettings
) -> tuple[np.ndarray, np.ndarray, float, int]:
    """(difference image, foreground mask, threshold, smoothing) at half scale (every
    other pixel) for an RGB frame and its 1/8-scale background.

    The difference is the largest channel difference (grey levels). Only when the frame
    is noisy (MAD above 2 grey levels) is the image box-filtered (``smooth``) first, so
    clean frames keep sharp edges; the smoothing used is returned (0: none).
    """
    st = settings
    half = cv2.resize(img, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_NEAREST)  # img[::2, ::2]
    h, w = half.shape[:2]
    bg = cv2.resize(bg_small, (w, h), interpolation=cv2.INTER_LINEAR)
    dmax = _max_channel_diff(half, bg)
    med, mad = _median_mad(dmax)
    smooth = 0
    if st.smooth and mad > 2.0:  # noisy: average the image before differencing
        smooth = st.smooth
        blurred = cv2.blur(img, (smooth, smooth))  # at full scale, as each blob's box is
        dmax = _max_channel_diff(
            cv2.resize(blurred, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_NEAREST), bg)
        med, mad = _median_mad(dmax)
    if st.threshold_method == "fixed":
        t = float(st.threshold_value)
    elif st.threshold_method == "otsu":
        otsu = cv2.threshold(dmax, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)[0]
        t = max(float(otsu), float(st.otsu_floor))
    else:  # "auto": noise-adaptive
        t = max(float(st.threshold_value), med + st.noise_k * max(mad, 0.5))
    mask = cv2.threshold(dmax, t, 255, cv2.THRESH_BINARY)[1]
    return dmax, cv2.morphologyEx(mask, cv2.MORPH_OPEN, _K2), t, smooth


def shadow(img: np.ndarray, bg: np.ndarray, chroma: float) -> np.ndarray:
    """Pixels that are the background darkened without a change of colour: shadow.

    A shadow scales the light falling on the belt, so every channel drops by about the
    same factor; a part changes the ratios (Cucchiara et al., *Detecting moving objects,
    ghosts and shadows in video streams*, IEEE PAMI 2003: shadows keep chromaticity).
    A shadow pixel is below 0.75 of the background in every channel and ``chroma`` bounds
    the spread of the three ratios, relative to their largest; 0 = off. ``img`` and ``bg``
    uint8 RGB (H, W, 3); the image is 3x3-averaged first; bool (H, W) out.
    """
    if chroma <= 0:
        return np.zeros(img.shape[:2], bool)
    mean = cv2.blur(img, (3, 3))
    out = _dark(mean, bg).view(bool)
    idx = np.flatnonzero(out)
    out.ravel()[idx] = _same_colour(mean.reshape(-1, 3), bg.reshape(-1, 3), idx, chroma)
    return out


def _dark(mean: np.ndarray, bg: np.ndarray) -> np.ndarray:
    """uint8 (H, W) 0/1: where each channel of ``mean`` (uint8 RGB (H, W, 3)) is below 0.75
    of ``bg`` + 1 (uint8 RGB), i.e. 4 mean < 3 (bg + 1) (saturated at 255): the ratio
    test of :func:`shadow` in integers (a quotient of integers up to 255 is never within
    a float's rounding of 3/4 unless equal to it)."""
    # ceil(3 (bg + 1) / 4) = round(0.75 bg + 1.125), exactly (multiples of 1/8)
    below = cv2.compare(mean, cv2.convertScaleAbs(bg, alpha=0.75, beta=1.125), cv2.CMP_LT)
    # all three 255: grey 255 (OpenCV's weights sum to one in fixed point; a zero
    # channel leaves at most 226)
    return cv2.threshold(cv2.cvtColor(below, cv2.COLOR_RGB2GRAY), 254, 1, cv2.THRESH_BINARY)[1]


def _same_colour(mean: np.ndarray, bg: np.ndarray, idx: np.ndarray, chroma: float,
                 bg_idx: np.ndarray | None = None) -> np.ndarray:
    """At the pixels ``idx`` of ``mean`` and ``bg_idx`` (default ``idx``) of ``bg`` ((N, 3)
    uint8), whether the three ratios mean / (bg + 1) (float32, ``cv2.divide``) spread by
    less than ``chroma`` of their largest: bool (len(idx),)."""
    bg = np.take(bg, idx if bg_idx is None else bg_idx, axis=0)
    red, green, blue = cv2.divide(np.take(mean, idx, axis=0), cv2.add(bg, 1), dtype=cv2.CV_32F).T
    rmax = np.maximum(np.maximum(red, green), blue)
    rmin = np.minimum(np.minimum(red, green), blue)
    return rmin > (1.0 - chroma) * rmax


def _drop_shadow(keep: np.ndarray, img: np.ndarray, bg: np.ndarray, chroma: float) -> None:
    """Clear the :func:`shadow` pixels of mask ``keep`` (uint8, img's shape), testing only
    its nonzero pixels, with the 3x3 mean over their bounding box and one pixel around
    it (the mean's support): the same shadow there as the whole image gives."""
    rx, ry, rw, rh = cv2.boundingRect(keep)
    if rw == 0 or rh == 0:
        return
    h, w = keep.shape
    xa, ya, xb, yb = max(rx - 1, 0), max(ry - 1, 0), min(rx + rw + 1, w), min(ry + rh + 1, h)
    mean = cv2.blur(img[ya:yb, xa:xb], (3, 3))
    box = keep[ya:yb, xa:xb]
    cand = cv2.bitwise_and(_dark(mean, bg[ya:yb, xa:xb]), box)  # 0/1 (box 0/1 or 0/255)
    idx = np.flatnonzero(cand.view(bool))
    if idx.size:
        ys, xs = np.divmod(idx, xb - xa)
        sh = _same_colour(mean.reshape(-1, 3), bg.reshape(-1, 3), idx, chroma,
                          (ys + ya) * w + xs + xa)
        box[ys[sh], xs[sh]] = 0


def find_blobs(view: FrameView) -> list[Blob]:
    """Outer contours of the half-scale foreground, refined at full scale each in its own
    box (:func:`_refine`); specks, and blobs far longer than any part (a rail, the table
    edge), are left out. A part touching such a long blob is cut off it by an opening."""
    contours, hier = cv2.findContours(view.mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    if hier is None:
        return []
    parts = list(_part_contours(view, contours, hier[0].tolist(), (0, 0), cut=True))
    n = MAX_WINDOWS
    return [b for i in range(0, len(parts), n) for b in _refine(view, parts[i : i + n])]


def _part_contours(view: FrameView, contours, hier, offset: tuple[int, int], *, cut: bool):
    """Half-scale outer contours that may be parts (in the mask's coordinates). A contour
    longer than any part is opened (3x3) and its pieces taken instead, once (``cut``)."""
    for i, c in enumerate(contours):
        if len(c) < 12 or hier[i][3] != -1:
            continue  # the smallest part's outline is some 80 px long (40 at half scale)
        x, y, bw, bh = cv2.boundingRect(c)
        if bw * bh < 5 or 4 * cv2.contourArea(c) < view.min_px:
            continue
        if 2 * max(bw, bh) <= view.max_px:
            yield c + offset if offset != (0, 0) else c
        elif cut and min(bw, bh) >= 8:  # a rail or an edge, with parts touching it? cut them
            ox, oy = offset[0] + x, offset[1] + y
            sub = np.zeros((bh, bw), np.uint8)
            cv2.drawContours(sub, [c], -1, 255, -1, offset=(-x, -y))
            sub = cv2.bitwise_and(sub, view.mask[oy : oy + bh, ox : ox + bw])
            sub = cv2.morphologyEx(sub, cv2.MORPH_OPEN, _K3)
            cs, hr = cv2.findContours(sub, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
            if hr is not None:
                yield from _part_contours(view, cs, hr[0].tolist(), (ox, oy), cut=False)


def _refine(view: FrameView, parts: list[np.ndarray]) -> list[Blob]:
    """The blobs of half-scale contours ``parts`` at full scale, each from its own box
    (and 8 px around it) as if alone: the difference there thresholded at ``edge_level``
    times the blob's median contrast (at least the frame's threshold), less shadow, near
    the contour's region. All boxes are processed at once, side by side in a
    :class:`~cell.vision._mosaic.Mosaic`."""
    st = view.settings
    h, w = view.fg.shape
    hh, hw = view.mask.shape
    x, y, bw, bh = np.array([cv2.boundingRect(c) for c in parts]).T
    hx0, hy0 = np.maximum(x - 4, 0), np.maximum(y - 4, 0)  # the box and 4 px, half scale
    hx1, hy1 = np.minimum(x + bw + 4, hw), np.minimum(y + bh + 4, hh)
    ring = max(view.smooth // 2, 1)  # the support of the 3x3 mean, or of the box filter
    mos = Mosaic(np.stack((2 * hx0, 2 * hy0, np.minimum(2 * hx1, w), np.minimum(2 * hy1, h)), 1),
                 view.bg_small, ring)
    img = mos.paste(view.img, ring)
    src = cv2.blur(img, (view.smooth, view.smooth)) if view.smooth else img
    d = _max_channel_diff(src, mos.bg)  # (undefined between boxes: every use is masked)
    fg = mos.open3(cv2.threshold(d, view.threshold, 255, cv2.THRESH_BINARY)[1])
    for k, (x0, y0, x1, y1) in enumerate(mos.boxes):
        view.fg[y0:y1, x0:x1] |= mos.window(fg, k)
    # each blob's foreground: near its half-scale region (dilated), not a neighbour's
    near = np.zeros((fg.shape[0] // 2, fg.shape[1] // 2), np.uint8)
    shift = (mos.at // 2 - np.stack((hx0, hy0), 1)).tolist()
    cv2.drawContours(near, [c + s for c, s in zip(parts, shift, strict=True)], -1, 1, -1)
    near = cv2.resize(cv2.dilate(near, _K3), fg.shape[::-1], interpolation=cv2.INTER_NEAREST)
    own = cv2.bitwise_and(fg, near)  # 0/1
    level = _levels(view, mos, d, own)
    above = cv2.compare(d, cv2.LUT(mos.label, level), cv2.CMP_GT)  # (none between boxes)
    keep = cv2.bitwise_and(cv2.dilate(own, _K3), above)
    if not view.backlit and st.shadow_chroma > 0:  # a light table casts no shadows
        _drop_shadow(keep, img, mos.bg, st.shadow_chroma)
    sub = mos.open3(keep)
    cs, hr = cv2.findContours(sub, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    if hr is None:
        return []
    return blobs_of_windows(mos, sub, cs, hr[0].tolist(), view.fg.shape,
                            view.settings.border_margin, view.min_px / 3)


def _levels(view: FrameView, mos: Mosaic, d: np.ndarray, own: np.ndarray) -> np.ndarray:
    """Each box's re-threshold, as a uint8 table (256,) by box (255 beyond them): the
    frame's threshold or ``edge_level`` times the box's median contrast (:meth:`Mosaic.
    medians` of ``d`` over ``own``), whichever is higher, floored (``cv2.threshold``
    compares uint8 pixels with the floor of its threshold)."""
    med, count = mos.medians(d, own)
    level = np.where(count > 0, np.maximum(view.threshold, view.settings.edge_level * med),
                     view.threshold)
    table = np.full(256, 255, np.uint8)
    table[: len(level)] = np.minimum(np.floor(level), 255)
    return table
