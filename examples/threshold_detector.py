"""A detector of your own, built from the syllabus functions, for the sort job.

Run it with::

    PYTHONPATH=examples cell run scenarios/sort.toml \
        --set vision.detector=threshold_detector:ThresholdDetector

It thresholds the grey image at Otsu's level, opens the mask, labels the regions, and for
each one reports where it lies on the belt (inverse perspective), its material (saturated
colour: plastic; grey: metal) and the catalogue kind whose area is nearest. It is far
weaker than ``PartDetector`` (dark parts on the dark belt vanish, touching parts merge,
yaw is only the major axis): the sort job's report shows by how much.
"""

from __future__ import annotations

import cv2
import numpy as np

from cell.catalogue import KINDS
from cell.sim.layout import BELT_TOP  # m: the surface the parts lie on (no MuJoCo needed)
from cell.vision import (
    Detection,
    colour_stats,
    label_components,
    opening,
    orientation,
    pixel_to_table,
    threshold_fixed,
    threshold_otsu,
)

AREAS = {name: k.length * k.width for name, k in KINDS.items()}  # m^2, roughly


class ThresholdDetector:
    """Otsu threshold, opening, labeling; material from saturation, kind from area."""

    def detect(self, image: np.ndarray, camera) -> list[Detection]:
        """The parts in ``image`` (uint8 RGB, (H, W, 3)) seen by ``camera`` (a
        ``CameraModel`` looking down on the belt), one ``Detection`` per region."""
        grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        mask = opening(threshold_fixed(grey, value=threshold_otsu(grey)), size=3)
        regions = label_components(mask, min_area=60)
        m_per_px = (camera.T_world_camera[2, 3] - BELT_TOP) / camera.K[0, 0]
        found = []
        for i in range(regions.count):
            x, y = pixel_to_table(camera, regions.centroids[i:i + 1], z=BELT_TOP)[0, :2]
            area = regions.areas[i] * m_per_px**2
            kind = min(AREAS, key=lambda k: abs(AREAS[k] - area))
            plastic = colour_stats(image, regions.mask(i + 1)).sat_mean > 0.35
            found.append(Detection(
                id=i + 1, material="plastic" if plastic else "metal", material_confidence=0.7,
                kind=kind, kind_confidence=0.7, centroid=tuple(regions.centroids[i]),
                yaw=-orientation(regions.mask(i + 1)), symmetry=KINDS[kind].symmetry,
                position=(float(x), float(y)), size=(KINDS[kind].length, KINDS[kind].width),
                partial=False))
        return found
