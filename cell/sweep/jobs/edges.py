"""The ``edges`` job: Canny at a pair of thresholds on rendered parts, scored against truth.

The scene is the detect job's. Its outline image, in grey and smoothed by ``job.blur``
passes of a 3x3 Gaussian, goes through :func:`cell.vision.canny` with ``high =
job.high`` and ``low = job.low_ratio * high`` (raw 3x3 Sobel magnitudes: a step of ``c``
grey levels gives about ``4 c``). Scored inside the belt's band against the true parts'
outlines (the boundary pixels of the segmentation):

- ``outline_closed``: the share of the parts fully in view whose outline closes: the
  edges (gaps up to ``job.max_gap`` px bridged) enclose at least 90 % of the part's
  pixels (those more than the bridge inside it), seen from outside its bounding box;
- ``outline_recall``: the share of true outline pixels with an edge within
  ``job.tolerance_px``;
- ``clutter``: the share of edge pixels farther than ``job.tolerance_px`` from any true
  outline (texture, noise, the belt's grain and edges): what a later step must reject;
- ``closure``: :func:`cell.vision.contour_closure`'s share of edge pixels on closed
  contours, over the band; ``edge_pixels`` and ``low`` (the low threshold used).

Timing: ``canny_ms``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from cell.config import check, setting
from cell.scenario import Scenario
from cell.sweep.jobs.detect import prepare, scene_key  # the detect job's scene (its gap_mm)

__all__ = ["METRICS", "TIMINGS", "Settings", "closed_outline", "measure", "prepare", "scene_key"]

METRICS = ("low", "parts", "outline_closed", "outline_recall", "clutter", "closure", "edge_pixels")
TIMINGS = ("canny_ms",)
_COVER = 0.9  # share of a part's inner pixels its closed outline must enclose


@dataclass(frozen=True)
class Settings:
    """The edges job's parameters (``[job]``)."""

    high: float = setting(150.0, lo=0.0, hi=10_000.0, doc="Canny's high threshold (raw 3x3 Sobel magnitude)")
    low_ratio: float = setting(0.4, lo=0.0, hi=1.0, doc="Canny's low threshold as a fraction of the high")
    blur: int = setting(1, lo=0, hi=20, doc="passes of a 3x3 Gaussian before Canny")
    max_gap: int = setting(1, lo=0, hi=5, doc="gaps in an outline up to this are bridged (px)")
    tolerance_px: float = setting(2.0, lo=0.0, hi=20.0, doc="an edge this near a true outline is on it (px)")
    gap_mm: float = setting(4.0, lo=0.0, hi=100.0,
                            doc="least gap between two parts' bounding circles in the scene (mm)")

    def __post_init__(self) -> None:
        check(self, "job")  # (built in code too: cell.config.check)



def closed_outline(edges: np.ndarray, part: np.ndarray, *, max_gap: int) -> bool:
    """Whether ``edges`` (bool, a window around one part) enclose the part's mask ``part``
    (bool, same window): after gaps up to ``max_gap`` are bridged, at least 90 % of the
    part's pixels deeper than the bridge are not reachable from the window's border."""
    import cv2

    k = np.ones((max_gap + 1, max_gap + 1), np.uint8)
    wall = cv2.dilate(edges.view(np.uint8), k) > 0 if max_gap else edges
    free = np.pad(~wall, 1, constant_values=True).view(np.uint8)
    _, labels = cv2.connectedComponents(free, connectivity=4)
    outside = labels[0, 0]
    enclosed = labels[1:-1, 1:-1] != outside
    inner = cv2.erode(part.view(np.uint8), np.ones((2 * max_gap + 3,) * 2, np.uint8)) > 0
    n = int(np.count_nonzero(inner))
    return n > 0 and np.count_nonzero(enclosed & inner) >= _COVER * n


def measure(scene: object, scenario: Scenario, settings: Settings) -> dict:
    import cv2

    from cell.sweep.scene import belt_rows
    from cell.vision.edges import canny, contour_closure
    from cell.vision.smoothing import gaussian_iterated

    grey = cv2.cvtColor(scene.image, cv2.COLOR_RGB2GRAY)
    grey = gaussian_iterated(grey, iterations=settings.blur)
    low = settings.low_ratio * settings.high
    t0 = time.perf_counter()
    edges = canny(grey, low=low, high=settings.high)
    spent = 1e3 * (time.perf_counter() - t0)
    first, last = belt_rows(scene.camera)
    seg = scene.seg
    mask = (seg > 0).view(np.uint8)
    outline = cv2.morphologyEx(mask, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
    to_outline = cv2.distanceTransform((~outline).view(np.uint8), cv2.DIST_L2, 3)
    to_edge = cv2.distanceTransform((~edges).view(np.uint8), cv2.DIST_L2, 3)
    band = slice(first, last + 1)
    e, o = edges[band], outline[band] & (mask[band] > 0)
    n_edge = int(np.count_nonzero(e))
    border = set(np.unique(np.concatenate([seg[0], seg[-1], seg[:, 0], seg[:, -1]])).tolist())
    closed = parts = 0
    for part in scene.parts:
        ys, xs = np.nonzero(seg == part.id)
        if ys.size < 30 or part.id in border:
            continue
        parts += 1
        y0, y1 = max(int(ys.min()) - 8, 0), int(ys.max()) + 9
        x0, x1 = max(int(xs.min()) - 8, 0), int(xs.max()) + 9
        closed += closed_outline(edges[y0:y1, x0:x1], seg[y0:y1, x0:x1] == part.id,
                                 max_gap=settings.max_gap)
    n_outline = int(np.count_nonzero(o))
    return {
        "low": low,
        "parts": parts,
        "outline_closed": closed / parts if parts else None,
        "outline_recall": (float(np.count_nonzero(to_edge[band][o] <= settings.tolerance_px)) / n_outline
                           if n_outline else None),
        "clutter": (float(np.count_nonzero(to_outline[band][e] > settings.tolerance_px)) / n_edge
                    if n_edge else None),
        "closure": contour_closure(e, max_gap=settings.max_gap).closure,
        "edge_pixels": n_edge,
        "canny_ms": spent,
    }
