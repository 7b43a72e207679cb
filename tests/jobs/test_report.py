"""detections.png: any valid detection is drawn without a warning, however far off it says it is."""

from __future__ import annotations

import math
import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from cell.errors import JobError
from cell.jobs.report import draw_detections, encode_png
from cell.sim.layout import BELT_TOP
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


@pytest.mark.parametrize("image", [np.zeros((48, 64), np.uint8), np.zeros((48, 64, 3), np.float32),
                                   np.zeros((48, 64, 4), np.uint8), np.zeros((0, 64, 3), np.uint8),
                                   [[0, 0, 0]]])
def test_an_image_not_uint8_rgb_is_one_job_error(image):  # was a cv2.error, or a grey PNG
    camera = SimpleNamespace(K=np.diag([500.0, 500.0, 1.0]), T_world_camera=np.eye(4))
    with pytest.raises(JobError, match="draw_detections: argument 'image': expected a uint8 RGB"):
        draw_detections(image, [], camera=camera)
    with pytest.raises(JobError, match="encode_png: argument 'image'"):
        encode_png(image)


SURE, REJECT = (40, 200, 60), (255, 150, 0)


def _camera():
    camera = SimpleNamespace(K=np.diag([500.0, 500.0, 1.0]), T_world_camera=np.eye(4))
    camera.T_world_camera[2, 3] = BELT_TOP + 1.0  # 500 px per metre on the belt
    return camera


def _det(*, yaw=0.0, partial=False):
    return Detection(id=1, material="metal", material_confidence=1.0, kind="bolt", kind_confidence=1.0,
                     centroid=(100.0, 100.0), yaw=yaw, symmetry=0, position=(0.0, 0.0),
                     size=(0.08, 0.004), partial=partial)


def test_a_partial_detection_is_drawn_orange_a_whole_one_green():
    image = np.zeros((200, 200, 3), np.uint8)
    whole = draw_detections(image, [_det()], camera=_camera())
    part = draw_detections(image, [_det(partial=True)], camera=_camera())
    assert tuple(whole[100, 100]) == SURE
    assert tuple(part[100, 100]) == REJECT


def test_the_box_turns_with_the_yaw_as_seen_from_above():
    """World y is image up: a bolt at yaw -45 deg (clockwise seen from above) lies from
    the top-left to the bottom-right of the image, not from bottom-left to top-right."""
    image = np.zeros((200, 200, 3), np.uint8)
    out = draw_detections(image, [_det(yaw=-math.pi / 4)], camera=_camera())
    assert out[113:118, 113:118].any()  # 15 px down-right of the centre: on the box
    assert not out[113:118, 82:87].any()  # 15 px down-left: off it
