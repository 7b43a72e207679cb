"""The sort job's eye: capture the pick zone under one or two presets and detect the parts.

A capture renders the overhead camera under each of the scenario's ``capture.presets``
(default: its ``lighting``) and runs the detector on each image through the
**calibrated** camera model. With two presets (``["back", "front"]``) the parts, their
outlines, kinds and positions come from the first image and each part's material from
the second: the detection of the second image nearest to it on the table (within
``_SAME_PART`` metres) lends its material; a part with no partner gets ``unknown``.

A frame the sensor delivers black (a camera blackout) is never acted on: the eye waits
``sort.retake_wait`` seconds of simulated time and retakes it, up to ``sort.retakes``
times, and then reports that it saw nothing usable.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell.camera import CameraModel
from cell.scenario import Scenario

__all__ = ["Capture", "Eye", "is_black", "merge_materials"]

_SAME_PART = 0.006  # m: two captures' detections this close on the table are one part
_BLACK_MEAN = 6.0  # grey levels: a frame darker than this on average...
_BLACK_SPREAD = 6.0  # ...and this flat carries no picture


@dataclass(frozen=True, eq=False)
class Capture:
    """What one look at the pick zone gave: the time ``t`` (s, simulated), the images by
    preset (uint8 (H, W, 3) each, in capture order), the ``detections`` (merged when two
    presets are taken), the ground-truth segmentation ``seg`` (int32 (H, W); only when
    asked for scoring or a replay, else None) and the ``retakes`` it needed."""

    t: float
    images: dict[str, np.ndarray]
    detections: list
    seg: np.ndarray | None
    retakes: int

    @property
    def image(self) -> np.ndarray:
        """The first (outline) image."""
        return next(iter(self.images.values()))


def is_black(image: np.ndarray) -> bool:
    """Whether a uint8 (H, W, 3) frame carries no picture (dark and flat: a blackout)."""
    return float(image.mean()) < _BLACK_MEAN and float(image.std()) < _BLACK_SPREAD


class Eye:
    """Captures and detections of ``world``'s overhead camera through ``camera`` (the
    calibrated model) with ``detector`` (from :func:`~cell.jobs.detectors.load_detector`:
    a user's is checked there); ``truth`` also renders the segmentation (for the
    report's scoring and the replay, never for a decision). ``timers`` (a dict of
    seconds) collects ``render`` and ``detect`` wall times; ``step(n)`` runs n physics
    steps while a blacked-out frame is retaken (default ``world.step``; the sort job's
    own, so that the time is counted as physics and the replay logs it)."""

    def __init__(self, world: object, camera: CameraModel, detector: object, scenario: Scenario,
                 *, truth: bool = False, timers: dict[str, float] | None = None,
                 step: Callable[[int], None] | None = None) -> None:
        self.world, self.camera, self.detector = world, camera, detector
        self._step = step
        self.presets = scenario.capture.presets or (scenario.lighting,)
        self.settings = scenario.sort
        self.truth = truth
        self.timers = timers if timers is not None else {}

    def _timed(self, key: str, fn, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            self.timers[key] = self.timers.get(key, 0.0) + time.perf_counter() - t0

    def _shoot(self) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
        images, seg = {}, None
        for k, preset in enumerate(self.presets):
            if len(self.presets) > 1 or self.world.lighting_name != preset:
                self.world.set_lighting(preset)
            frame = self._timed("render", self.world.render, "overhead", depth=False,
                                seg=self.truth and k == 0)
            images[preset] = frame.rgb
            seg = frame.seg if self.truth and k == 0 else seg
        return images, seg

    def look(self) -> Capture | None:
        """A usable capture of the pick zone now, retaken while the frames are black;
        None when every retake was black."""
        for retake in range(self.settings.retakes + 1):
            if retake:
                step = self._step if self._step is not None else self.world.step
                step(max(1, round(self.settings.retake_wait / self.world.model.opt.timestep)))
            t = self.world.time
            images, seg = self._shoot()
            if any(is_black(im) for im in images.values()):
                continue
            found = [self._timed("detect", self.detector.detect, im, self.camera)
                     for im in images.values()]
            detections = merge_materials(found[0], found[1]) if len(found) == 2 else found[0]
            return Capture(t, images, detections, seg, retake)
        return None

    def second_opinion(self, det: object, preset: str) -> object | None:
        """``det`` with the material seen under lighting ``preset`` (one more image, the
        outline's preset restored for the next look); None when that image is black or
        shows no part within ``_SAME_PART`` of ``det``."""
        self.world.set_lighting(preset)
        try:
            image = self._timed("render", self.world.render, "overhead", depth=False, seg=False).rgb
        finally:
            self.world.set_lighting(self.presets[0])
        if is_black(image):
            return None
        found = self._timed("detect", self.detector.detect, image, self.camera)
        merged = merge_materials([det], found)[0]
        return merged if merged.material != "unknown" else None


def merge_materials(outline: list, material: list) -> list:
    """The detections of the outline image, each with the material of the nearest
    detection of the material image within ``_SAME_PART`` (6 mm) on the table
    (``unknown``, confidence 0, if none is near). Detections are ``Detection``s."""
    placed = [d for d in material if d.position is not None]
    out = []
    for d in outline:
        best = None
        if d.position is not None and placed:
            gaps = [np.hypot(d.position[0] - m.position[0], d.position[1] - m.position[1])
                    for m in placed]
            if min(gaps) <= _SAME_PART:
                best = placed[int(np.argmin(gaps))]
        out.append(dataclasses.replace(
            d, material=best.material if best else "unknown",
            material_confidence=best.material_confidence if best else 0.0))
    return out
