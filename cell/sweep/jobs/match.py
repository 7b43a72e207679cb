"""The ``match`` job: find each part's template in a changed image (SSD, SAD, NCC or ORB).

The scene lays the scenario's parts out in the overhead view and renders it twice (two
frames of the same layout, each with its own sensor noise). Each part's template is cut
from the first frame (its bounding box in the segmentation, ``job.pad_px`` wider: a
template a user teaches from one image). The second frame is changed as the study asks:
grey levels ``I' = job.contrast * I + job.brightness`` (saturated to 0..255), then turned
by ``job.rotation_deg`` about the part's template centre (``cv2.warpAffine``, the border
replicated), so the part stays where it was and turns. The template is searched for in
the belt's band of that image by ``job.method``: ``ssd``, ``sad``, ``ncc``
(:mod:`cell.vision.template`; the best score's window centre) or ``orb``
(:func:`cell.vision.orb_match`: the template's centre through the RANSAC homography; no
match is a miss). A hit is a peak within ``job.hit_px`` of where the template's centre
truly is.

Figures per run (over the parts fully in view): ``templates``, ``hit_rate``,
``peak_error_px_median`` and ``peak_error_px_mean`` over the hits (how precisely a found
part is located), ``peak_error_px_median_all`` over every part (misses included).
Timing: ``match_ms`` (every template of the run).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from cell.config import check, setting
from cell.scenario import Scenario

__all__ = ["METHODS", "METRICS", "TIMINGS", "Settings", "find", "measure", "perturb", "prepare", "scene_key"]

METHODS = ("ssd", "sad", "ncc", "orb")
METRICS = ("templates", "hit_rate", "peak_error_px_median", "peak_error_px_mean",
           "peak_error_px_median_all")
TIMINGS = ("match_ms",)


@dataclass(frozen=True)
class Settings:
    """The match job's parameters (``[job]``)."""

    method: str = setting("ncc", choices=METHODS, doc="ssd, sad, ncc or orb")
    brightness: float = setting(0.0, lo=-255.0, hi=255.0, doc="grey levels added to the searched image")
    contrast: float = setting(1.0, lo=0.0, hi=10.0, doc="factor on the searched image's grey levels")
    rotation_deg: float = setting(0.0, lo=-180.0, hi=180.0,
                                  doc="turn of each part in the searched image (deg)")
    hit_px: float = setting(3.0, lo=0.0, hi=1000.0, doc="a peak within this of the truth is a hit (px)")
    pad_px: int = setting(4, lo=0, hi=100, doc="margin of a template around its part (px)")
    gap_mm: float = setting(4.0, lo=0.0, hi=100.0,
                            doc="least gap between two parts' bounding circles in the scene (mm)")

    def __post_init__(self) -> None:
        check(self, "job")  # (built in code too: cell.config.check)



def scene_key(scenario: Scenario, settings: Settings) -> tuple:
    from cell.sweep.scene import scene_scenario

    return (scene_scenario(scenario), settings.gap_mm, "retake")


def prepare(scenario: Scenario, settings: Settings) -> object:
    from cell.sweep.scene import render_scene, scene_scenario

    return render_scene(scene_scenario(scenario), gap=settings.gap_mm / 1e3, retakes=1)


def perturb(grey: np.ndarray, settings: Settings) -> np.ndarray:
    """``grey`` with the study's brightness and contrast change (uint8, saturated)."""
    import cv2

    return cv2.addWeighted(grey, settings.contrast, grey, 0.0, settings.brightness)  # saturated


def find(template: np.ndarray, image: np.ndarray, method: str) -> tuple[float, float] | None:
    """Where ``template``'s centre is found in ``image`` (x, y pixels), or None (ORB found
    no match)."""
    from cell.vision.features import orb_match
    from cell.vision.template import best_match, match_ncc, match_sad, match_ssd

    if method == "orb":
        found = orb_match(template, image)
        return None if found is None else found.centre
    scores = {"ssd": match_ssd, "sad": match_sad, "ncc": match_ncc}[method](image, template)
    return best_match(scores, template.shape, method=method).centre


def _templates(scene: object, grey: np.ndarray, pad: int) -> list[tuple[np.ndarray, float, float]]:
    """(template, centre x, centre y) of each part fully in view, from ``grey``."""
    h, w = grey.shape
    seg = scene.seg
    border = set(np.unique(np.concatenate([seg[0], seg[-1], seg[:, 0], seg[:, -1]])).tolist())
    out = []
    for part in scene.parts:
        ys, xs = np.nonzero(seg == part.id)
        if ys.size < 30 or part.id in border:
            continue
        y0, y1 = int(ys.min()) - pad, int(ys.max()) + pad + 1
        x0, x1 = int(xs.min()) - pad, int(xs.max()) + pad + 1
        if y0 < 0 or x0 < 0 or y1 > h or x1 > w:
            continue
        out.append((np.ascontiguousarray(grey[y0:y1, x0:x1]), (x0 + x1 - 1) / 2, (y0 + y1 - 1) / 2))
    return out


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def measure(scene: object, scenario: Scenario, settings: Settings) -> dict:
    import cv2

    from cell.sweep.scene import belt_rows

    reference = cv2.cvtColor(scene.image, cv2.COLOR_RGB2GRAY)
    searched = perturb(cv2.cvtColor(scene.retakes[0], cv2.COLOR_RGB2GRAY), settings)
    first, last = belt_rows(scene.camera)
    h, w = searched.shape
    errors, hits = [], 0
    t0 = time.perf_counter()
    templates = _templates(scene, reference, settings.pad_px)
    for template, cx, cy in templates:
        turn = cv2.getRotationMatrix2D((cx, cy), settings.rotation_deg, 1.0)
        image = cv2.warpAffine(searched, turn, (w, h), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_REPLICATE) if settings.rotation_deg else searched
        top = max(0, first - template.shape[0])
        band = np.ascontiguousarray(image[top: min(h, last + template.shape[0] + 1)])
        found = find(template, band, settings.method) if band.shape[0] >= template.shape[0] else None
        if found is None:
            errors.append(math.inf)
            continue
        error = math.hypot(found[0] - cx, found[1] + top - cy)
        errors.append(error)
        hits += error <= settings.hit_px
    spent = 1e3 * (time.perf_counter() - t0)
    hit_errors = [e for e in errors if e <= settings.hit_px]
    n = len(templates)
    return {
        "templates": n,
        "hit_rate": hits / n if n else None,
        "peak_error_px_median": float(np.median(hit_errors)) if hit_errors else None,
        "peak_error_px_mean": float(np.mean(hit_errors)) if hit_errors else None,
        "peak_error_px_median_all": _finite(float(np.median(errors))) if errors else None,
        "match_ms": spent,
    }
