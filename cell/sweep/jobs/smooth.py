"""The ``smooth`` job: a noisy frame smoothed, then segmented and detected.

The scene is the detect job's, rendered with the scenario's sensor noise
(``sensor.noise_std``: Gaussian, ``sensor.salt_pepper``: salt and pepper). ``job.filter``
smooths its outline image ``job.iterations`` times with a ``job.ksize`` square kernel:
``gaussian`` (:func:`cell.vision.gaussian_iterated`: repeated passes of a small Gaussian
are one wider Gaussian), ``median`` (:func:`cell.vision.median`, repeated), or ``none``.
The smoothed image then goes through the detector's foreground step and the whole
detector (set ``vision.smooth = 0`` in the study so the detector adds no smoothing of its
own). Figures: ``fg_iou`` (the foreground against the true parts in the belt's band) and
the detect job's accuracy figures. Timings: ``filter_ms``, ``detect_ms``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from cell.config import check, setting
from cell.scenario import Scenario
from cell.sweep.jobs.detect import prepare, scene_key  # the detect job's scene (its gap_mm)

__all__ = ["FILTERS", "METRICS", "TIMINGS", "Settings", "measure", "prepare", "scene_key", "smooth"]

FILTERS = ("none", "gaussian", "median")
_ACCURACY = ("recall", "false_detections", "kind_accuracy", "material_accuracy",
             "classification_accuracy", "position_error_mm_mean", "position_error_mm_max")
METRICS = ("fg_iou", *_ACCURACY)
TIMINGS = ("filter_ms", "detect_ms")


@dataclass(frozen=True)
class Settings:
    """The smooth job's parameters (``[job]``)."""

    filter: str = setting("gaussian", choices=FILTERS, doc="none, gaussian or median")
    iterations: int = setting(1, lo=0, hi=100, doc="passes of the filter (0: none)")
    ksize: int = setting(3, lo=3, hi=15, doc="kernel size (px, odd)")
    gap_mm: float = setting(4.0, lo=0.0, hi=100.0,
                            doc="least gap between two parts' bounding circles in the scene (mm)")

    def __post_init__(self) -> None:
        check(self, "job")  # (built in code too: cell.config.check)

    def _validate(self, where: str) -> None:
        from cell.errors import ScenarioError

        if self.ksize % 2 == 0:
            raise ScenarioError(f"{where}: key 'job.ksize' must be odd, got {self.ksize}")


def smooth(image: np.ndarray, settings: Settings) -> np.ndarray:
    """``image`` filtered by ``settings`` (a copy when there is nothing to do)."""
    from cell.vision.smoothing import gaussian_iterated, median

    if settings.filter == "none" or settings.iterations == 0:
        return image.copy()
    if settings.filter == "gaussian":
        return gaussian_iterated(image, iterations=settings.iterations, ksize=settings.ksize)
    out = image
    for _ in range(settings.iterations):
        out = median(out, ksize=settings.ksize)
    return out


def measure(scene: object, scenario: Scenario, settings: Settings) -> dict:
    from cell.jobs.detectors import load_detector
    from cell.sweep.scoring import figures, foreground_iou, score_frame
    from cell.vision.steps.footprint import TablePlane
    from cell.vision.steps.foreground import find_foreground

    t0 = time.perf_counter()
    image = smooth(scene.image, settings)
    t1 = time.perf_counter()
    detections = load_detector(scenario.vision).detect(image, scene.camera)
    t2 = time.perf_counter()
    scored = figures(score_frame(scene, detections))
    plane = TablePlane(scene.camera, scenario.vision.plane_z)
    fg = find_foreground(image, scenario.vision, m_per_px=plane.m_per_px)
    out = {"fg_iou": foreground_iou(fg.mask, scene)}
    out.update({k: scored[k] for k in _ACCURACY})
    out.update(filter_ms=1e3 * (t1 - t0), detect_ms=1e3 * (t2 - t1))
    return out
