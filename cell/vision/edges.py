"""Edges: Sobel gradients, Canny with hysteresis, and how closed the edge contours are.

References: I. Sobel and G. Feldman, "A 3x3 isotropic gradient operator", 1968;
J. Canny, "A computational approach to edge detection", IEEE PAMI 8(6), 1986
(non-maximum suppression and hysteresis: a weak edge pixel survives only when it is
connected to a strong one); Gonzalez & Woods, *Digital Image Processing*, 4th ed.,
10.2; OpenCV ``cv2.Sobel``, ``cv2.Canny``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import (
    MAX_SIZE,
    check_choice,
    check_finite,
    check_gray,
    check_int,
    check_mask,
    check_range,
)

__all__ = ["EdgeClosure", "Gradient", "canny", "contour_closure", "sobel"]

MAX_AREA = 2**31 - 1  # pixels: the largest min_loop_area and min_fragment
MAX_THRESHOLD = 1e6  # above any Sobel magnitude of a uint8 image (aperture 7: about 2.3e5)


def _check_bool(name: str, value: object) -> None:
    if not isinstance(value, bool | np.bool_):
        raise VisionError(f"argument '{name}': expected True or False, got {value!r}")


@dataclass(frozen=True, eq=False)
class Gradient:
    """Image gradient: ``gx``, ``gy`` (float32 (H, W); see :func:`sobel` for units),
    ``magnitude`` = hypot(gx, gy) and ``direction`` = atan2(gy, gx) (radians, x right,
    y down)."""

    gx: np.ndarray
    gy: np.ndarray
    magnitude: np.ndarray
    direction: np.ndarray


def sobel(image: np.ndarray, *, ksize: int = 3, normalize: bool = False) -> Gradient:
    """Sobel derivatives of a grey image.

    Parameters
    ----------
    image : uint8 or float32 (H, W); float values must be finite.
    ksize : 1, 3, 5 or 7 (kernel size).
    normalize : divide by the kernel's gain so a ramp of slope 1 grey level per
        pixel gives a derivative of 1 (the raw 3x3 Sobel gives 8 on such a ramp and
        about 4 c across a step of c grey levels); when False, the raw
        ``cv2.Sobel`` values, as ``cv2.Canny`` thresholds them.

    Wraps ``cv2.Sobel`` (float32 output, border reflect-101).
    """
    image = check_finite("image", check_gray("image", image, dtypes=(np.uint8, np.float32)))
    check_choice("ksize", ksize, (1, 3, 5, 7))
    _check_bool("normalize", normalize)
    scale = 1.0
    if normalize:
        # sum of |derivative taps| * smoothing taps: slope-1 ramp -> gain
        d, s = cv2.getDerivKernels(1, 0, ksize)
        ramp = np.arange(len(d), dtype=np.float64) - len(d) // 2
        scale = 1.0 / float((d.ravel() * ramp).sum() * s.sum())
    gx = cv2.Sobel(image, cv2.CV_32F, 1, 0, ksize=ksize, scale=scale)
    gy = cv2.Sobel(image, cv2.CV_32F, 0, 1, ksize=ksize, scale=scale)
    return Gradient(gx, gy, cv2.magnitude(gx, gy), np.arctan2(gy, gx).astype(np.float32))


def canny(
    image: np.ndarray, *, low: float, high: float, aperture: int = 3, l2: bool = True
) -> np.ndarray:
    """Canny edges: Sobel gradient, non-maximum suppression, hysteresis.

    Pixels with gradient magnitude above ``high`` start edges; pixels above ``low``
    join them when connected (8-neighbourhood) to such a start; the rest are dropped.

    Parameters
    ----------
    image : uint8 (H, W) (smooth it first if it is noisy).
    low, high : hysteresis thresholds on the raw Sobel magnitude (``aperture`` 3:
        a step of ``c`` grey levels gives a magnitude of about ``4 c``),
        0 <= low <= high <= 1e6.
    aperture : Sobel size, 3, 5 or 7.
    l2 : use the L2 norm of the gradient (else |gx| + |gy|).

    Returns a bool (H, W) edge map, one pixel wide. Wraps ``cv2.Canny``.
    """
    image = check_gray("image", image)
    check_choice("aperture", aperture, (3, 5, 7))
    _check_bool("l2", l2)
    low = check_range("low", low, 0.0, MAX_THRESHOLD)
    high = check_range("high", high, 0.0, MAX_THRESHOLD)
    if low > high:
        raise VisionError(f"arguments 'low', 'high': need 0 <= low <= high, got {low}, {high}")
    return cv2.Canny(image, float(low), float(high), apertureSize=aperture, L2gradient=bool(l2)) > 0


@dataclass(frozen=True)
class EdgeClosure:
    """How well an edge map's contours close.

    ``edge_pixels``; ``fragments``: 8-connected edge chains of at least
    ``min_fragment`` pixels; ``endpoints``: edge pixels with exactly one 8-neighbour
    (a closed contour has none); ``loops``: regions of at least ``min_loop_area``
    pixels fully enclosed by edges; ``largest_loop_area`` and ``enclosed_area`` (all
    loops together; pixels, edges excluded, the band the bridging of gaps covers given
    back: a closed contour's loop has the same area whatever ``max_gap``, within a few
    pixels along a curve, unless the bridging fills it); ``closure``:
    share of the edge pixels that border an enclosed region, 0 (nothing closes) to 1
    (every edge pixel lies on a closed contour).
    """

    edge_pixels: int
    fragments: int
    endpoints: int
    loops: int
    largest_loop_area: int
    enclosed_area: int
    closure: float


def contour_closure(
    edges: np.ndarray, *, max_gap: int = 2, min_loop_area: int = 20, min_fragment: int = 3
) -> EdgeClosure:
    """Measure the closure of the contours in a binary edge map.

    A region counts as enclosed when the background (4-connected) cannot reach the
    image border from it without crossing an edge pixel, after gaps of up to
    ``max_gap`` pixels are bridged (the edges are dilated by a
    ``(max_gap + 1)``-square first; Canny leaves such gaps at junctions).

    Parameters
    ----------
    edges : bool or uint8 (H, W), thin edges (as from :func:`canny`).
    max_gap : largest gap (pixels) still counted as closed, 0 (strict) to 4095; a
        gap beyond twice the image's larger side bridges as much as that.
    min_loop_area : smallest enclosed region counted as a loop (pixels, 0 to
        2**31 - 1); smaller ones are noise rings.
    min_fragment : smallest edge chain counted as a fragment (pixels, 0 to 2**31 - 1).
    """
    e = check_mask("edges", edges)
    max_gap = min(check_int("max_gap", max_gap, 0, MAX_SIZE), 2 * max(e.shape))
    min_loop_area = check_int("min_loop_area", min_loop_area, 0, MAX_AREA)
    min_fragment = check_int("min_fragment", min_fragment, 0, MAX_AREA)
    n_edge = int(e.sum())
    if n_edge == 0:
        return EdgeClosure(0, 0, 0, 0, 0, 0, 0.0)
    n, _, stats, _ = cv2.connectedComponentsWithStats(e.view(np.uint8), connectivity=8)
    fragments = int(np.sum(stats[1:, cv2.CC_STAT_AREA] >= min_fragment))
    neigh = cv2.filter2D(e.view(np.uint8), cv2.CV_16S, np.ones((3, 3), np.float32),
                         borderType=cv2.BORDER_CONSTANT) - e
    endpoints = int(np.sum(e & (neigh == 1)))
    # gaps up to max_gap bridged: the edges dilated by a (max_gap + 1)-square, which for
    # an odd max_gap reaches one pixel farther on one side (OpenCV anchors an even kernel
    # past its middle)
    square = np.ones((max_gap + 1, max_gap + 1), np.uint8)
    wall = cv2.dilate(e.view(np.uint8), square) > 0 if max_gap > 0 else e
    free = np.pad(~wall, 1, constant_values=True).view(np.uint8)
    _, lab, st, _ = cv2.connectedComponentsWithStats(free, connectivity=4)
    lab = lab[1:-1, 1:-1]
    outside = lab[0, 0] if free[0, 0] else -1  # the padded frame's component
    enclosed_ids = [i for i in range(1, len(st)) if i != outside
                    and st[i, cv2.CC_STAT_AREA] >= min_loop_area]
    if not enclosed_ids:
        return EdgeClosure(n_edge, fragments, endpoints, 0, 0, 0, 0.0)
    enclosed = np.where(np.isin(lab, enclosed_ids), lab, 0)
    if max_gap > 0:  # give each loop back the band the dilation took from it: the mirrored
        # square from its pixels, up to the edges (an edge line stops it on either side)
        back = max_gap // 2
        enclosed = cv2.dilate(enclosed.astype(np.float32), square, anchor=(back, back))
        enclosed = np.where(e, 0, enclosed).astype(np.int64)
    areas = np.bincount(enclosed.ravel(), minlength=len(st))[enclosed_ids]
    reach = np.ones((2 * ((max_gap + 1) // 2) + 3,) * 2, np.uint8)  # the wider side's band, + 1
    touching = cv2.dilate((enclosed > 0).view(np.uint8), reach) > 0
    return EdgeClosure(
        edge_pixels=n_edge,
        fragments=fragments,
        endpoints=endpoints,
        loops=len(enclosed_ids),
        largest_loop_area=int(areas.max()),
        enclosed_area=int(areas.sum()),
        closure=float(np.sum(touching & e)) / n_edge,
    )
