"""detections.png: any valid detection is drawn without a warning, however far off it says it is."""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np

from cell.jobs.report import draw_detections
from cell.vision.detector import Detection


def test_a_huge_size_or_yaw_is_drawn_without_warnings():
    camera = SimpleNamespace(K=np.diag([500.0, 500.0, 1.0]), T_world_camera=np.eye(4))
    camera.T_world_camera[2, 3] = 1.0
    far = Detection(id=1, material="metal", material_confidence=1.0, kind="washer", kind_confidence=1.0,
                    centroid=(30.0, 20.0), yaw=1e300, symmetry=0, position=(1e300, -1e300),
                    size=(1e300, 1e300), partial=False)
    image = np.zeros((48, 64, 3), np.uint8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        drawn = draw_detections(image, [far], camera=camera)
    assert drawn.shape == image.shape and drawn.any()
