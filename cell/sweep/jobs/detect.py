"""The ``detect`` job: the scenario's detector on a rendered scene, scored against truth.

The scene (:func:`cell.sweep.scene.render_scene`) lays the scenario's parts out in the
overhead view and renders them under each capture preset; the detector named by
``vision.detector`` (ours by default) runs through the true camera model (the vision
alone, without a calibration's error). With two capture presets (``capture.presets =
["back", "front"]``) the parts and their poses come from the first image and each
part's material from the second, as the sort job's eye does: the detection of the second
image within 6 mm on the table lends its material.

Figures: ``parts`` fully in view and ``found``, ``recall``, ``false_detections``,
``kind_accuracy``, ``material_accuracy`` and ``classification_accuracy`` (both right;
among the found), ``material_unknown``,
position error mean and max (mm), yaw error max (deg), and ``fg_iou``: our detector's
foreground step (``vision.segmentation``) against the true parts' pixels in the belt's
band (None for a user's detector). Timings: ``detect_ms`` (the detector on all images of
the run) and ``scene_s`` (rendering the scene, shared by the runs that use it).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from cell.config import check, setting
from cell.scenario import Scenario

__all__ = ["METRICS", "TIMINGS", "Settings", "detect_all", "measure", "prepare",
           "scene_key"]

METRICS = ("parts", "found", "recall", "false_detections", "kind_accuracy", "material_accuracy",
           "material_unknown", "classification_accuracy", "position_error_mm_mean", "position_error_mm_max",
           "yaw_error_deg_max", "fg_iou")
TIMINGS = ("detect_ms", "scene_s")


@dataclass(frozen=True)
class Settings:
    """The detect job's parameters (``[job]``)."""

    gap_mm: float = setting(4.0, lo=0.0, hi=100.0,
                            doc="least gap between two parts' bounding circles in the scene (mm)")

    def __post_init__(self) -> None:
        check(self, "job")  # (built in code too: cell.config.check)



def scene_key(scenario: Scenario, settings: Settings) -> tuple:
    """What the run renders: the scene's scenario and ``settings.gap_mm`` (the compress,
    smooth and edges jobs share this scene and read only their own ``gap_mm``)."""
    from cell.sweep.scene import scene_scenario

    return (scene_scenario(scenario), settings.gap_mm)


def prepare(scenario: Scenario, settings: Settings) -> object:
    from cell.sweep.scene import render_scene, scene_scenario

    return render_scene(scene_scenario(scenario), gap=settings.gap_mm / 1e3)


def detect_all(detector: object, images: list, camera: object) -> list:
    """The detections of one capture: of its one image, or merged from two (the sort
    job's rule, :func:`cell.jobs.eye.merge_materials`)."""
    from cell.jobs.eye import merge_materials

    found = [detector.detect(image, camera) for image in images]
    return merge_materials(found[0], found[1]) if len(found) == 2 else found[0]


def measure(scene: object, scenario: Scenario, settings: Settings) -> dict:
    from cell.jobs.detectors import load_detector
    from cell.sweep.scoring import figures, foreground_iou, score_frame

    detector = load_detector(scenario.vision)
    t0 = time.perf_counter()
    detections = detect_all(detector, list(scene.images.values()), scene.camera)
    detect_ms = 1e3 * (time.perf_counter() - t0)
    out = figures(score_frame(scene, detections))
    out["fg_iou"] = None
    if scenario.vision.detector == "parts":
        from cell.vision.steps.footprint import TablePlane
        from cell.vision.steps.foreground import find_foreground

        plane = TablePlane(scene.camera, scenario.vision.plane_z)
        fg = find_foreground(scene.image, scenario.vision, m_per_px=plane.m_per_px)
        out["fg_iou"] = foreground_iou(fg.mask, scene)
    out["detect_ms"] = detect_ms
    out["scene_s"] = scene.render_s
    return out
