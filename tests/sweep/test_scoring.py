"""cell.sweep.scoring: detections matched to a scene's parts, and the figures of a frame."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from cell.sweep.scoring import score_frame


def _scene():
    seg = np.zeros((60, 80), np.int32)
    seg[20:30, 20:30] = 1  # a part in full view
    seg[0:10, 50:60] = 2  # a part cut by the top border
    parts = [SimpleNamespace(id=1, kind="disc", material="metal", position=(0.1, 0.4), yaw=0.0),
             SimpleNamespace(id=2, kind="disc", material="metal", position=(0.2, 0.4), yaw=0.0)]
    return SimpleNamespace(seg=seg, parts=parts)


def _det(u, v):
    return SimpleNamespace(centroid=(u, v), partial=False, kind="disc", material="metal",
                           position=(0.1, 0.4), yaw=0.0)


def test_a_second_detection_of_one_part_is_a_false_detection():
    s = score_frame(_scene(), [_det(24.5, 24.5), _det(25.0, 25.0)])
    assert (s.found, s.false) == (1, 1)


def test_a_part_on_the_image_border_is_not_counted():
    s = score_frame(_scene(), [_det(24.5, 24.5), _det(54.5, 4.5)])
    assert s.parts == 1 and s.found == 1 and s.false == 0
