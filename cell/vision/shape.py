"""Shape descriptors of one binary region.

Area, perimeter, aspect ratio (length / width of the minimum-area rectangle),
circularity ``P^2 / (4 pi A)`` (1 for a disc, larger for anything else: 1.27 for a
square), compactness ``A / P^2`` (1 / (4 pi) for a disc), the seven Hu moment
invariants, orientation from the second central moments, and the number of holes.

Every function takes a ``mask``: bool, or uint8 with nonzero inside, (H, W), meant to
hold one region. Given several, what needs an outline (the perimeter, and with it
circularity and compactness's denominator; the holes) is taken of the largest
8-connected region by pixel count; the area, the rectangle and the moments of every set
pixel. Conventions: image axes x right, y down (pixels); angles in radians measured
from +x towards +y (clockwise on screen), in (-pi/2, pi/2].

References: Gonzalez & Woods, *Digital Image Processing*, 4th ed., 11.2-11.4;
M.-K. Hu, "Visual pattern recognition by moment invariants", IRE Trans. IT 8(2),
1962; OpenCV ``cv2.moments``, ``cv2.HuMoments``, ``cv2.minAreaRect``,
``cv2.arcLength``, ``cv2.findContours`` (Suzuki & Abe 1985).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_int, check_mask

__all__ = [
    "ShapeDescriptors",
    "aspect_ratio",
    "circularity",
    "compactness",
    "count_holes",
    "describe_shape",
    "hu_moments",
    "orientation",
    "perimeter",
]

MAX_AREA = 2**31 - 1  # pixels: the largest min_area and min_hole_area


@dataclass(frozen=True)
class ShapeDescriptors:
    """The descriptors of one region (pixels, radians); see the module docstring.

    ``length``/``width``: sides of the minimum-area rectangle (length >= width),
    ``rect_angle``: direction of its long side. ``filled_area``: area with holes filled.
    """

    area: int
    filled_area: int
    perimeter: float
    length: float
    width: float
    rect_angle: float
    aspect_ratio: float
    circularity: float
    compactness: float
    hu: tuple[float, ...]
    orientation: float
    centroid: tuple[float, float]
    holes: int


def _largest_region(mask: np.ndarray) -> np.ndarray:
    """uint8 (H, W), 1 on the largest 8-connected region of ``mask`` by pixel count (a
    thin wire of 400 pixels beats a 16 x 16 part; the area inside an outline through the
    pixel centres would not), the first in OpenCV's label order on a tie."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.view(np.uint8), connectivity=8)
    if n < 2:
        raise VisionError("argument 'mask': the mask is empty")
    return (labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))).view(np.uint8)


def _outer_contour(region: np.ndarray) -> np.ndarray:
    """The outer boundary of one region (uint8, as :func:`_largest_region` gives)."""
    contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    return contours[0]


def _length(contour: np.ndarray) -> float:
    """A closed contour's length (0 for a single pixel's)."""
    return 0.0 if len(contour) == 1 else float(cv2.arcLength(contour, closed=True))


def perimeter(mask: np.ndarray) -> float:
    """Length (pixels) of the outer boundary of the largest region (by pixel count).

    The boundary is the 8-connected chain of boundary pixel centres
    (``cv2.findContours``); its length counts 1 per straight step and sqrt(2) per
    diagonal one (``cv2.arcLength``). Holes do not add to it.
    """
    return _length(_outer_contour(_largest_region(check_mask("mask", mask))))


def _min_area_rect(mask: np.ndarray) -> tuple[float, float, float]:
    """(length, width, angle) of the minimum-area rectangle around the region's pixels.

    Pixels count as unit squares: the rectangle is fitted to the pixel corners, so a
    single pixel is 1 x 1.
    """
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        raise VisionError("argument 'mask': the mask is empty")
    corners = np.concatenate(
        [np.stack([xs + dx, ys + dy], 1) for dx in (-0.5, 0.5) for dy in (-0.5, 0.5)]
    ).astype(np.float32)
    (_, _), (w, h), angle = cv2.minAreaRect(cv2.convexHull(corners))
    theta = math.radians(angle)
    if w < h:
        w, h, theta = h, w, theta + math.pi / 2
    theta = math.pi / 2 - (math.pi / 2 - theta) % math.pi  # in (-pi/2, pi/2]
    return float(w), float(h), theta


def aspect_ratio(mask: np.ndarray) -> float:
    """Length / width of the minimum-area (rotated) rectangle around the region (>= 1)."""
    length, width, _ = _min_area_rect(check_mask("mask", mask))
    return length / width


def _filled(contour: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """bool ``shape``: the pixels inside ``contour``, holes filled."""
    out = np.zeros(shape, np.uint8)
    cv2.drawContours(out, [contour], -1, 1, thickness=cv2.FILLED)
    return out.astype(bool)


def circularity(mask: np.ndarray) -> float:
    """``P^2 / (4 pi A)`` of the outer boundary: 1 for a disc, 4/pi for a square.

    ``P`` is :func:`perimeter`; ``A`` is the pixel count with holes filled (the
    outline's area). A digital disc of radius r px comes out near 1 + 0.5/r because
    the boundary chain runs through pixel centres and steps in 45-degree moves. A tiny
    region comes out below 1, as no real shape can: its chain through the pixel centres
    is much shorter than its edge (a 2x2 square gives 0.32, a 1x3 line 0.42, a single
    pixel 0). The measure means something from a few pixels of radius on.
    """
    m = check_mask("mask", mask)
    contour = _outer_contour(_largest_region(m))
    return _length(contour) ** 2 / (4 * math.pi * _filled(contour, m.shape).sum())


def _nonzero(p: float) -> float:
    """The perimeter ``p``, or the error of a single pixel's (0)."""
    if p == 0:
        raise VisionError("argument 'mask': the region is a single pixel, whose outline has "
                          "length 0, so its compactness A / P^2 is undefined")
    return p


def compactness(mask: np.ndarray) -> float:
    """``A / P^2`` (pixel count over squared perimeter): 1/(4 pi) ~ 0.080 for a disc.

    Undefined for a single pixel (its outline, through the pixel centre, has length
    0): a ``VisionError``, as for an empty mask.
    """
    m = check_mask("mask", mask)
    p = _nonzero(perimeter(m))
    return float(m.sum()) / (p * p)


def hu_moments(mask: np.ndarray) -> np.ndarray:
    """The seven Hu invariants (7,) of the region, invariant to translation, scale and
    rotation (the seventh changes sign under reflection). Wraps ``cv2.HuMoments``.
    An empty mask is a ``VisionError``."""
    m = check_mask("mask", mask)
    if not m.any():
        raise VisionError("argument 'mask': the mask is empty")
    return cv2.HuMoments(cv2.moments(m.view(np.uint8), binaryImage=True)).ravel()


def orientation(mask: np.ndarray) -> float:
    """Direction (radians, (-pi/2, pi/2]) of the region's major axis from the second
    central moments: ``0.5 * atan2(2 mu11, mu20 - mu02)``, x right, y down.

    Meaningless (returns 0) for a region with equal principal moments (a disc or a
    square): check ``mu20 - mu02`` and ``mu11`` against each other if that matters.
    """
    m = check_mask("mask", mask)
    mom = cv2.moments(m.view(np.uint8), binaryImage=True)
    if mom["m00"] == 0:
        raise VisionError("argument 'mask': the mask is empty")
    theta = 0.5 * math.atan2(2 * mom["mu11"], mom["mu20"] - mom["mu02"])
    return theta if theta > -math.pi / 2 else theta + math.pi


def count_holes(mask: np.ndarray, *, min_area: int = 1) -> int:
    """Number of holes (background regions enclosed by the region, 4-connected,
    at least ``min_area`` pixels, 0 to 2**31 - 1) in the largest region of ``mask``."""
    m = check_mask("mask", mask)
    min_area = check_int("min_area", min_area, 0, MAX_AREA)
    region = _largest_region(m)
    return _holes(region, _filled(_outer_contour(region), m.shape), min_area)


def _holes(region: np.ndarray, filled: np.ndarray, min_area: int) -> int:
    """Holes of ``region`` (uint8) of at least ``min_area`` pixels, ``filled`` its pixels
    with holes filled (an island in a hole is in it)."""
    holes = (filled & ~region.view(bool)).view(np.uint8)
    n, _, stats, _ = cv2.connectedComponentsWithStats(holes, connectivity=4)
    return int(np.sum(stats[1:, cv2.CC_STAT_AREA] >= min_area))


def describe_shape(mask: np.ndarray, *, min_hole_area: int = 4) -> ShapeDescriptors:
    """Every descriptor of the (largest) region of ``mask`` in one pass.

    Parameters
    ----------
    mask : bool or uint8 (H, W), one region (if several, descriptors that need an
        outline use the largest; area and moments use all set pixels).
    min_hole_area : holes smaller than this (pixels, 0 to 2**31 - 1) are noise
        and not counted.

    A single-pixel region (outline of length 0, compactness undefined) is a
    ``VisionError``, as is an empty mask.
    """
    m = check_mask("mask", mask)
    min_hole_area = check_int("min_hole_area", min_hole_area, 0, MAX_AREA)
    if not m.any():
        raise VisionError("argument 'mask': the mask is empty")
    region = _largest_region(m)
    contour = _outer_contour(region)
    p = _nonzero(_length(contour))
    filled = _filled(contour, m.shape)
    length, width, angle = _min_area_rect(m)
    mom = cv2.moments(m.view(np.uint8), binaryImage=True)
    area = int(m.sum())
    return ShapeDescriptors(
        area=area,
        filled_area=int(filled.sum()),
        perimeter=p,
        length=length,
        width=width,
        rect_angle=angle,
        aspect_ratio=length / width,
        circularity=p * p / (4 * math.pi * filled.sum()),
        compactness=area / (p * p),
        hu=tuple(float(v) for v in cv2.HuMoments(mom).ravel()),
        orientation=orientation(m),
        centroid=(mom["m10"] / mom["m00"], mom["m01"] / mom["m00"]),
        holes=_holes(region, filled, min_hole_area),
    )
