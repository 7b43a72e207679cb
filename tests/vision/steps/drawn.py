"""Drawn frames for the detector's step tests: a straight-down camera over a flat belt.

``camera()`` looks straight down from 0.40 m above the table plane (z = 0.08 m, as the
default ``vision.plane_z``) over the belt's centre line (world ``(0, BELT_Y)``, inside the
default ``vision.belt_y``), so 1 mm on the table is ``PX_PER_MM`` pixels at the image
centre; ``frame()`` is the belt (its catalogue-like colour, a little sensor noise);
``mm(x, y)`` converts table millimetres around the image centre to pixels.
"""

from __future__ import annotations

import numpy as np

from cell.camera import CameraModel

W, H = 640, 480
F = 660.0  # focal length (px): 1.65 px/mm at 0.40 m
HEIGHT = 0.40  # camera above the table plane (m)
PX_PER_MM = F * 1e-3 / HEIGHT
BELT = (60, 80, 110)
BELT_Y = 0.45  # world y under the image centre: the belt's centre line (cell.sim.layout)


def camera() -> CameraModel:
    K = np.array([[F, 0, (W - 1) / 2], [0, F, (H - 1) / 2], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])  # looking down, image x = world x
    T[:3, 3] = (0.0, BELT_Y, 0.08 + HEIGHT)
    return CameraModel(W, H, K, np.zeros(5), T)


def frame(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = np.empty((H, W, 3), np.float64)
    img[:] = BELT
    img += rng.normal(0, 1.0, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)


def mm(x: float, y: float) -> tuple[int, int]:
    """Pixel (u, v) of the table point (x, y) mm from the image centre (world y is up)."""
    return int(round((W - 1) / 2 + x * PX_PER_MM)), int(round((H - 1) / 2 - y * PX_PER_MM))


def px(length_mm: float) -> int:
    return int(round(length_mm * PX_PER_MM))
