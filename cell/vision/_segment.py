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

from cell.vision._blob import Blob
from cell.vision._blobwindows import blobs_of_windows
from cell.vision._contours import contours, opened_contours
from cell.vision._fillchain import fill_chains
from cell.vision._footprint import Geometry
from cell.vision._median_kernel import median15
from cell.vision._mosaic import Mosaic, drop_shadow, refine, window
from cell.vision._segment_kernel import (
    difference,
    median_mad,
    noise_mad,
    open2,
    outer_boxes,
    probe_levels,
    upscale_axis,
)
from cell.vision._smooth_kernel import box_difference, smoothing_taps
from cell.vision.settings import VisionSettings

__all__: list[str] = []  # private to cell.vision

_BG_SCALE = 8  # the background model's downscale factor


@dataclass
class FrameView:
    """One frame as the detector's steps share it.

    ``img`` uint8 RGB (H, W, 3); ``bg_small`` its background estimate at 1/8 scale;
    ``dmax`` uint8 (H/2, W/2) the largest channel difference from it at half scale,
    ``mask`` its foreground (0/255) at ``threshold`` grey levels; ``fg`` uint8 (H, W)
    the full-scale foreground, filled in around each blob as it is refined; ``smooth``
    the aperture of the filter applied before differencing (0: none; Gaussian of
    ``settings.smooth_sigma``, or a box filter when that is 0); ``backlit`` whether the
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
            self._sigma = 1.4826 * noise_mad(self.img) / math.sqrt(2)
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
    15-wide median (that of ``cv2.medianBlur``, 120 px at full scale, borders mirrored)
    over every 8th pixel. Back-lit when the background's median brightness reaches
    ``settings.backlight_level`` and it is nearly colourless.
    """
    small = _every_8th(img)
    bg_small = np.empty_like(small)
    median15(small, bg_small)
    level, spread = probe_levels(bg_small)  # every 24 px: largest, largest - smallest channel
    return bg_small, level >= settings.backlight_level and spread < 40


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


def _median_mad(dmax: np.ndarray) -> tuple[float, float]:
    """Median and MAD (scaled to a Gaussian sigma) of every 4th pixel, from its histogram."""
    med, mad = median_mad(dmax)
    return float(med), mad * 1.4826


def foreground(
    img: np.ndarray, bg_small: np.ndarray, settings: VisionSettings
) -> tuple[np.ndarray, np.ndarray, float, int]:
    """(difference image, foreground mask, threshold, smoothing) at half scale (every
    other pixel, as ``cv2.resize`` by 0.5, nearest) for an RGB frame and its 1/8-scale
    background (resized to half scale, bilinear).

    The difference is the largest channel difference (grey levels). Only when the frame
    is noisy (MAD above 2 grey levels) is the image smoothed (``smooth`` px: Gaussian of
    ``smooth_sigma``, or a box filter) first, so
    clean frames keep sharp edges; the smoothing used is returned (0: none).
    """
    st = settings
    hh, ww = img.shape[:2]
    h, w = round(hh / 2), round(ww / 2)  # (OpenCV's rounding, half to even)
    dmax = np.empty((h, w), np.uint8)
    bg = cv2.resize(bg_small, (w, h), interpolation=cv2.INTER_LINEAR).reshape(h, 3 * w)
    flat = img.reshape(hh, 3 * ww)
    difference(flat, bg, True, dmax)  # (the rows _median_mad reads)
    med, mad = _median_mad(dmax)
    smooth = 0
    if st.smooth and mad > 2.0:  # noisy: average the image before differencing
        smooth = st.smooth
        taps = smoothing_taps(smooth, st.smooth_sigma)
        box_difference(flat, bg, smooth, taps, dmax)  # at full scale, as each blob's box is
        med, mad = _median_mad(dmax)
    else:
        difference(flat, bg, False, dmax)
    if st.threshold_method == "fixed":
        t = float(st.threshold_value)
    elif st.threshold_method == "otsu":
        otsu = cv2.threshold(dmax, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)[0]
        t = max(float(otsu), float(st.otsu_floor))
    else:  # "auto": noise-adaptive
        t = max(float(st.threshold_value), med + st.noise_k * max(mad, 0.5))
    mask = np.empty((h, w), np.uint8)
    open2(dmax, math.floor(t), mask)
    return dmax, mask, t, smooth


def shadow(img: np.ndarray, bg: np.ndarray, chroma: float) -> np.ndarray:
    """Pixels that are the background darkened without a change of colour: shadow.

    A shadow scales the light falling on the belt, so every channel drops by about the
    same factor; a part changes the ratios (Cucchiara et al., *Detecting moving objects,
    ghosts and shadows in video streams*, IEEE PAMI 2003: shadows keep chromaticity).
    A shadow pixel is below 0.75 of the background in every channel and ``chroma`` bounds
    the spread of the three ratios, relative to their largest; 0 = off. ``img`` and ``bg``
    uint8 RGB (H, W, 3); the image is 3x3-averaged first; bool (H, W) out. This is the
    definition in OpenCV calls; the detector applies it compiled (:func:`_drop_shadow`).
    """
    if chroma <= 0:
        return np.zeros(img.shape[:2], bool)
    mean = cv2.blur(img, (3, 3))
    below = cv2.compare(mean, cv2.convertScaleAbs(bg, alpha=0.75, beta=1.125), cv2.CMP_LT)
    out = below.min(axis=2) > 0
    ratios = cv2.divide(mean, cv2.add(bg, 1), dtype=cv2.CV_32F)
    out &= ratios.min(axis=2) > (1.0 - chroma) * ratios.max(axis=2)
    return out


def _drop_shadow(keep: np.ndarray, img: np.ndarray, bg: np.ndarray, chroma: float) -> None:
    """Clear the :func:`shadow` pixels of mask ``keep`` (uint8, img's shape), testing only
    its nonzero pixels, as the refinement does (:func:`~cell.vision._mosaic.drop_shadow`)."""
    if chroma > 0:
        h, w = keep.shape
        win = np.empty((h + 2, 3 * (w + 2)), np.uint8)
        window(img.reshape(h, 3 * w), 0, 0, h, w, 1, win)
        padded = np.zeros((h + 2, w + 2), np.uint8)
        padded[1:-1, 1:-1] = keep > 0
        drop_shadow(padded, win, 1, np.ascontiguousarray(bg).reshape(h, 3 * w), h, w,
                    np.float32(1.0 - chroma), np.empty(3 * (w + 2), np.int64))
        keep[padded[1:-1, 1:-1] == 0] = 0


def find_blobs(view: FrameView) -> list[Blob]:
    """Outer contours of the half-scale foreground, refined at full scale each in its own
    box (:func:`_refine`); specks, and blobs far longer than any part (a rail, the table
    edge), are left out. A part touching such a long blob is cut off it by an opening."""
    pts, starts, hier = contours(view.mask)
    if not len(hier):
        return []
    parts = list(_part_contours(view, pts, starts, hier, (0, 0), cut=True))
    return _refine(view, parts) if parts else []


def _part_contours(view: FrameView, pts: np.ndarray, starts: np.ndarray, hier: np.ndarray,
                   offset: tuple[int, int], *, cut: bool,
                   within: tuple[np.ndarray, int, int] | None = None):
    """Half-scale outer contours that may be parts (in the mask's coordinates, (k, 1, 2)
    integer pixels as ``cv2.findContours`` gives them), each with its bounding box (x, y,
    w, h), chosen by :func:`~cell.vision._segment_kernel.outer_boxes` from the borders
    ``pts``, ``starts``, ``hier`` of :func:`~cell.vision._contours.contours`
    (``RETR_CCOMP``). A contour longer than any part is opened (3x3) and its pieces taken
    instead, once (``cut``).

    The opening is that of the mask in the long contour's box: other blobs there are
    apart from it (not 8-adjacent), so they open apart and trace apart, and the pieces
    are the same, in the same order, as those of the contour's filled region alone;
    the others' pieces are told by a point outside the contour (``within``: the
    contour and the pieces' offset in its coordinates)."""
    rows = outer_boxes(pts, np.diff(starts), hier, view.min_px, view.max_px).tolist()
    for i, x, y, bw, bh, long in rows:
        c = pts[starts[i] : starts[i + 1]].reshape(-1, 1, 2)
        if not long:
            if within is not None and cv2.pointPolygonTest(
                    within[0], (float(c[0, 0, 0] + within[1]), float(c[0, 0, 1] + within[2])),
                    False) < 0:
                continue  # a piece of another blob in the long contour's box
            if offset == (0, 0):
                yield c, (x, y, bw, bh)
            else:
                yield c + offset, (x + offset[0], y + offset[1], bw, bh)
        elif cut:  # a rail or an edge, with parts touching it? cut them
            ox, oy = offset[0] + x, offset[1] + y
            sub_pts, sub_starts, sub_hier = opened_contours(view.mask, ox, oy, bw, bh)
            if len(sub_hier):
                yield from _part_contours(view, sub_pts, sub_starts, sub_hier, (ox, oy),
                                          cut=False, within=(c, x, y))


def _refine(view: FrameView, parts: list[tuple[np.ndarray, tuple[int, int, int, int]]]
            ) -> list[Blob]:
    """The blobs of half-scale contours ``parts`` (with their bounding boxes) at full
    scale, each from its own box (and 8 px around it) as if alone: the difference there
    thresholded at ``edge_level`` times the blob's median contrast (at least the frame's
    threshold), less shadow, near the contour's region (compiled:
    :func:`~cell.vision._mosaic.refine`; the region filled as ``cv2.drawContours``
    fills it, :func:`~cell.vision._fillchain.fill_chains`). The results lie side by side
    in a :class:`~cell.vision._mosaic.Mosaic`, traced at once (as ``cv2.findContours``
    traces it, :func:`~cell.vision._contours.contours`)."""
    st = view.settings
    h, w = view.fg.shape
    hh, hw = view.mask.shape
    boxes, corners = [], []  # full-scale windows; their half-scale corners
    for _, (x, y, bw, bh) in parts:
        hx0, hy0 = max(x - 4, 0), max(y - 4, 0)  # the box and 4 px, half scale
        boxes.append((2 * hx0, 2 * hy0, min(2 * (x + bw + 4), 2 * hw, w),
                      min(2 * (y + bh + 4), 2 * hh, h)))
        corners.append((hx0, hy0))
    mos = Mosaic(boxes, max(view.smooth // 2, 1))  # (the support of the box filter)
    # each blob's foreground: near its half-scale region (dilated), not a neighbour's
    near = np.zeros((mos.shape[0] // 2 + 2, mos.shape[1] // 2 + 2), np.uint8)  # (framed)
    chains = [c for c, _ in parts]
    fill_chains(near, np.concatenate(chains, dtype=np.int32).reshape(-1, 2),
                np.cumsum([0] + [len(c) for c in chains]),
                np.array([(mx // 2 + 1 - hx0, my // 2 + 1 - hy0) for (mx, my), (hx0, hy0)
                          in zip(mos.at_list, corners, strict=True)], np.int64), 1)
    keep = 1.0 if view.backlit or st.shadow_chroma <= 0 else 1.0 - st.shadow_chroma
    hs, ws = view.bg_small.shape[:2]
    sub = np.zeros(mos.shape, np.uint8)
    refine(view.img, view.bg_small, upscale_axis(hs, h, False), upscale_axis(ws, w, True),
           np.array(boxes, np.int64), mos.at, near, view.threshold, view.smooth,
           smoothing_taps(view.smooth, st.smooth_sigma), st.edge_level,
           np.float32(keep), view.fg, sub)  # (a light table casts no shadows)
    pts, starts, hier = contours(sub)
    return blobs_of_windows(mos, sub, pts, starts, hier, view.fg.shape,
                            view.settings.border_margin, view.min_px / 3, view.geo)


def warm_up() -> None:
    """Load (or compile, on the very first run) every compiled kernel of segmentation,
    on a made-up 64x64 frame with one square part, clean and then noisy (box-filtered),
    and the cut of a long blob, so a detector's first frame is as fast as its others."""
    rng = np.random.default_rng(0)
    img = np.full((64, 64, 3), (60, 80, 110), np.uint8)
    img[20:44, 24:40] = (200, 120, 40)
    for noise in (0, 12):
        frame = np.clip(img + rng.normal(0, noise, img.shape), 0, 255).astype(np.uint8)
        settings = VisionSettings()
        bg_small, backlit = background(frame, settings)
        dmax, mask, t, smooth = foreground(frame, bg_small, settings)
        view = FrameView(frame, bg_small, dmax, mask, t, smooth, backlit, None, settings,
                         max_px=1000, min_px=10.0)
        find_blobs(view)
        opened_contours(mask, 1, 1, 30, 30)  # (the cut of a long blob)
        view.noise_sigma()
