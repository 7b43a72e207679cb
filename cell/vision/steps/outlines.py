"""Step 2, outlines: one outline per blob, on the part's edge whatever its contrast.

The foreground's outer contours (``cv2.findContours``) give the blobs. With the belt
segmentation each blob is then re-thresholded in its own box at a fraction
(``edge_level``) of its own contrast's lower quartile, never below the frame's own
threshold, so a bright part's outline does not swell by the blur around it (a faint
part's outline is the threshold's: under dim and raking light, most are); pixels that are
the belt in other light (darker or brighter in every channel by one factor: a shadow, a
spot's pool of light; Cucchiara et al., *Detecting moving objects, ghosts and shadows in
video streams*, IEEE PAMI 2003) are dropped. A blob much
longer than any part holds a rail or the table's edge: its long straight runs are taken
out (openings by a line), so a part that touches it is kept.

Each contour (``cv2.findContours`` traces the centres of the edge pixels) is moved half a
pixel outward, onto the region's edge, along its outward normals (the tangent over five
points turned by 90 degrees), which the footprint step needs to tell top edges from
bottom ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.vision.settings import VisionSettings
from cell.vision.steps.foreground import Foreground
from cell.vision.steps.material import PartPixels

__all__ = ["Outline", "Ring", "find_outlines", "is_faint", "outline_of_mask", "shadow"]

_SQUARE = np.ones((3, 3), np.uint8)
_NEAR = np.ones((5, 5), np.uint8)  # a blob's surroundings: its pixels dilated by 2 px
_MIN_HOLE_PX = 12.0  # px^2: a smaller hole is noise (the smallest part hole is ~200 px^2)


@dataclass(frozen=True)
class Ring:
    """A closed outline: ``points`` (N, 2) float pixels on the region's edge and
    ``normals`` (N, 2) the outward unit normals (into the hole, for a hole)."""

    points: np.ndarray
    normals: np.ndarray


@dataclass(frozen=True)
class Outline:
    """One blob: its ``outer`` ring and ``holes``; ``partial`` when it touches the image
    border; ``pixels`` the blob's own pixels; ``area`` (px^2, holes excluded) and
    ``centroid`` (u, v, px) of those pixels."""

    outer: Ring
    holes: tuple[Ring, ...]
    partial: bool
    pixels: PartPixels
    area: float
    centroid: tuple[float, float]


def ring(contour: np.ndarray, *, hole: bool) -> Ring:
    """The :class:`Ring` of a ``cv2.findContours`` contour ((N, 1, 2) int32)."""
    p = contour.reshape(-1, 2).astype(np.float64)
    i = np.arange(len(p))
    tangent = p[(i + 2) % len(p)] - p[i - 2]  # (index -1, -2 wrap around)
    # findContours runs outer borders and holes opposite ways: the signed area says which
    clockwise = cv2.contourArea(contour, oriented=True) < 0
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    if clockwise != hole:
        normal = -normal
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-9)[:, None]
    return Ring(p + 0.5 * normal, normal)


def outline_of_mask(mask: np.ndarray, x0: int, y0: int, *, frame: tuple[int, int],
                    margin: int = 1, min_area: float = 0.0) -> list[Outline]:
    """The outlines of the regions of ``mask`` (uint8, 255 inside, 0 outside), whose
    top-left pixel lies at (x0, y0) of a frame of size ``frame`` (width, height); a region
    within ``margin`` px of the frame's border is partial; regions under ``min_area`` px^2
    are left out."""
    contours, hierarchy = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE,
                                           offset=(x0, y0))
    if not contours:
        return []
    out = []
    alone = int(np.count_nonzero(hierarchy[0, :, 3] < 0)) == 1  # one region: its pixels are the mask's
    for i, c in enumerate(contours):
        if hierarchy[0, i, 3] >= 0 or len(c) < 3:
            continue  # a hole: taken with its outer contour
        holes = [contours[j] for j in _children(hierarchy[0], i)
                 if cv2.contourArea(contours[j]) >= _MIN_HOLE_PX]
        own = mask
        if not alone:
            own = np.zeros_like(mask)
            cv2.drawContours(own, [c, *holes], -1, 255, cv2.FILLED, offset=(-x0, -y0))
            own[mask == 0] = 0
        m = cv2.moments(own, binaryImage=True)
        if m["m00"] < max(min_area, 1.0):
            continue
        bx, by, bw, bh = cv2.boundingRect(c)
        partial = (bx <= margin or by <= margin or bx + bw >= frame[0] - margin
                   or by + bh >= frame[1] - margin)
        sub = own[by - y0: by - y0 + bh, bx - x0: bx + bw - x0]
        out.append(Outline(ring(c, hole=False), tuple(ring(h, hole=True) for h in holes),
                           partial, PartPixels(bx, by, np.ascontiguousarray(sub)), m["m00"],
                           (m["m10"] / m["m00"] + x0, m["m01"] / m["m00"] + y0)))
    return out


def is_faint(pixels: PartPixels, fg: Foreground, contrast: float) -> bool:
    """Whether the brightest tenth of a region's ``pixels`` stands less than ``contrast``
    times ``fg.threshold`` from the belt (``fg.difference``; ``contrast`` 0: never):
    belt texture, noise at the threshold, or a part at the noise level (a grey part
    under dim light, in fragments), whose outline says nothing of its shape."""
    h, w = pixels.mask.shape
    diff = fg.difference[pixels.y0:pixels.y0 + h, pixels.x0:pixels.x0 + w][pixels.mask > 0]
    if contrast <= 0 or diff.size == 0:
        return False
    brightest_tenth = float(np.quantile(diff, 0.9, method="lower"))  # its lower edge
    return brightest_tenth < contrast * fg.threshold


def _children(hierarchy: np.ndarray, i: int) -> list[int]:
    """The holes of outer contour ``i`` (``RETR_CCOMP``'s two-level hierarchy)."""
    out, j = [], hierarchy[i, 2]
    while j >= 0:
        out.append(j)
        j = hierarchy[j, 0]
    return out


def shadow(image: np.ndarray, belt: np.ndarray, *, chroma: float, noise: float = 0.0) -> np.ndarray:
    """Pixels that are the belt (or the table beside it) in other light: darker (below
    0.75, a shadow) or brighter (above 1.33, a spot's pool of light) in every channel by
    about one factor, the three ratios to the belt within ``chroma`` of their largest
    (3x3 mean), where the belt is bright enough for the ratios to mean something (its
    darkest channel at least 4 ``noise``). ``image``, ``belt`` uint8 RGB (H, W, 3); bool
    (H, W) out. Parts change the ratios: the belt is blue, no part is a blue of its shade."""
    mean = cv2.split(cv2.blur(image, (3, 3)).astype(np.float32))
    ref = cv2.split(belt.astype(np.float32))
    darker = brighter = lit_enough = True
    for m, r in zip(mean, ref, strict=True):  # per channel
        darker = darker & (m < 0.75 * r + 1.125)
        brighter = brighter & (m > 1.33 * r + 2.0)
        lit_enough = lit_enough & (r >= 4 * noise)
    ratios = [m / (r + 1.0) for m, r in zip(mean, ref, strict=True)]
    low = np.minimum(np.minimum(ratios[0], ratios[1]), ratios[2])
    high = np.maximum(np.maximum(ratios[0], ratios[1]), ratios[2])
    return (darker | brighter) & (low > (1.0 - chroma) * high) & lit_enough


def _refined(region: np.ndarray, x0: int, y0: int, fg: Foreground, settings: VisionSettings
             ) -> np.ndarray:
    """The pixels of ``region`` (uint8, a blob's near surroundings at full scale, top-left
    corner at (x0, y0)) that differ from the belt by ``edge_level`` of the lower quartile
    of the blob's contrast, less shadows (see the module docstring)."""
    y1, x1 = y0 + region.shape[0], x0 + region.shape[1]
    diff = fg.difference[y0:y1, x0:x1]
    inside = (region > 0) & (fg.mask[y0:y1, x0:x1] > 0)
    if not inside.any():
        return np.zeros_like(region)
    level = max(fg.threshold, settings.edge_level * _quantile(diff[inside], 0.25))
    keep = np.where((region > 0) & (diff > level), np.uint8(255), np.uint8(0))
    if settings.shadow_chroma > 0 and not fg.backlit:
        belt = fg.belt.median_in(x0, y0, x1, y1)
        keep[shadow(fg.image[y0:y1, x0:x1], belt, chroma=settings.shadow_chroma,
                    noise=fg.noise)] = 0
    return keep


def _quantile(values: np.ndarray, q: float) -> float:
    """The ``q`` quantile of ``values`` (1-D): the element of rank floor(q (n - 1)) in
    order (``np.partition``: the lower of the two ``np.percentile`` interpolates)."""
    k = int(q * (values.size - 1))
    return float(np.partition(values, k)[k])


def _groups(mask: np.ndarray, max_px: float) -> list[np.ndarray]:
    """Contours of the foreground's pixels grouped with those within 2 px (a faint ring
    broken by the threshold stays one blob). A group longer than ``max_px`` holds a rail
    or the belt's edge: straight runs longer than that, along the rows or the columns
    (openings by a line), are taken out with 2 px around them, then specks (a 3x3
    opening), and the rest is grouped again."""
    near = cv2.dilate(mask, _NEAR)
    groups, _ = cv2.findContours(near, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    out = []
    length = int(max_px)
    for c in groups:
        bx, by, bw, bh = cv2.boundingRect(c)
        if max(bw, bh) <= max_px:
            out.append(c)
            continue
        box = np.zeros((bh, bw), np.uint8)  # the group's own pixels: not a neighbour's in its box
        cv2.drawContours(box, [c], -1, 255, cv2.FILLED, offset=(-bx, -by))
        box &= mask[by:by + bh, bx:bx + bw]
        rails = cv2.max(cv2.morphologyEx(box, cv2.MORPH_OPEN, np.ones((1, length), np.uint8)),
                        cv2.morphologyEx(box, cv2.MORPH_OPEN, np.ones((length, 1), np.uint8)))
        rest = cv2.morphologyEx(box & ~cv2.dilate(rails, _NEAR), cv2.MORPH_OPEN, _SQUARE)
        pieces, _ = cv2.findContours(cv2.dilate(rest, _NEAR), cv2.RETR_EXTERNAL,
                                     cv2.CHAIN_APPROX_NONE, offset=(bx, by))
        out += [p for p in pieces if max(cv2.boundingRect(p)[2:]) <= max_px]
    return out


def find_outlines(fg: Foreground, settings: VisionSettings, *, min_px: float,
                  max_px: float) -> list[Outline]:
    """The blobs of a frame's foreground: groups whose outline (dilated by 2 px) covers at
    least ``min_px`` px^2, the regions in them from a third of that, boxes no
    longer than ``max_px`` px (see the module docstring)."""
    h, w = fg.mask.shape
    out: list[Outline] = []
    claimed = np.zeros((h, w), np.uint8)  # 255: a blob's own pixel (each belongs to one)
    for c in _groups(fg.mask, max_px):
        if cv2.contourArea(c) < min_px:
            continue
        x0, y0, bw, bh = cv2.boundingRect(c)
        region = np.zeros((bh, bw), np.uint8)
        cv2.drawContours(region, [c], -1, 255, cv2.FILLED, offset=(-x0, -y0))
        region &= ~claimed[y0:y0 + bh, x0:x0 + bw]
        if settings.segmentation == "belt":
            mask = _refined(region, x0, y0, fg, settings)
        else:
            mask = region & fg.mask[y0:y0 + bh, x0:x0 + bw]
        found = outline_of_mask(mask, x0, y0, frame=(w, h), margin=settings.border_margin,
                                min_area=min_px / 3)
        for blob in found:
            px = blob.pixels
            claimed[px.y0:px.y0 + px.mask.shape[0], px.x0:px.x0 + px.mask.shape[1]] |= px.mask
        out += found
    return out
