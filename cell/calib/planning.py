"""Where to put the wrist camera for the calibration views (pure geometry, no simulator).

Each view looks at a point near the board's centre from a point on a sphere around it:
distance drawn in the scenario's range, tilt of the view axis from the board's normal up
to ``max_tilt``, azimuth of the tilt spread evenly around the board (golden-angle steps,
so any first n views are spread too), and a turn about the view axis up to ``max_roll``.
Views whose flange-to-flange motions turn about many different axes by tens of degrees
make ``AX = XB`` well conditioned (Tsai and Lenz, IEEE TRA 5(3), 1989: the error falls
with the angle between the motions' rotation axes and with their rotation angles), and
tilted views pin down the focal length and the principal point (Zhang, PAMI 2000).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.calib.transforms import invert, make_transform, transform_from_rvec

__all__ = ["ViewPlan", "look_at", "plan_views"]

_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))  # rad
_AIM_JITTER = 0.015  # m: the aim point wanders this far (uniform, x and y) around the board


@dataclass(frozen=True, eq=False)
class ViewPlan:
    """One planned view: ``T_base_camera`` the camera pose aimed at (4x4, m) and
    ``T_base_flange`` the flange pose that puts it there by the rough camera mount (4x4, m);
    ``tilt_deg``, ``azimuth_deg``, ``roll_deg`` and ``distance`` (m) describe it."""

    T_base_camera: np.ndarray
    T_base_flange: np.ndarray
    tilt_deg: float
    azimuth_deg: float
    roll_deg: float
    distance: float


def look_at(eye: np.ndarray, target: np.ndarray, *, roll: float = 0.0) -> np.ndarray:
    """``T_base_camera`` (4x4) of an OpenCV camera (z forward, y down) at ``eye`` (m)
    looking at ``target`` (m), its x axis as near the base's x as the view allows, then
    turned by ``roll`` (rad) about the view axis."""
    z = np.asarray(target, float) - np.asarray(eye, float)
    z /= np.linalg.norm(z)
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - (ref @ z) * z
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z], axis=1) @ transform_from_rvec([0.0, 0.0, roll], np.zeros(3))[:3, :3]
    return make_transform(R, eye)


def plan_views(settings: object, rng: np.random.Generator, *, count: int, start: int = 0) -> list[ViewPlan]:
    """``count`` views (the ``start``-th onwards of the golden-angle sequence) from the
    ``[calibration]`` settings: board position, distance range, ``max_tilt``, ``max_roll``
    (deg) and the rough ``camera_offset`` in the flange frame (m). Random draws come only
    from ``rng``."""
    centre = np.asarray(settings.board_position, dtype=np.float64)
    T_flange_camera_guess = make_transform(np.eye(3), settings.camera_offset)
    near, far = settings.distance
    max_tilt = np.radians(settings.max_tilt)
    plans = []
    for k in range(start, start + count):
        azimuth = (k * _GOLDEN_ANGLE + rng.uniform(-0.2, 0.2)) % (2 * np.pi)
        tilt = max_tilt * np.sqrt(rng.uniform(0.15, 1.0))  # more views at larger tilts
        roll = np.radians(settings.max_roll) * rng.uniform(-1.0, 1.0)
        distance = rng.uniform(near, far)
        aim = centre + np.append(rng.uniform(-_AIM_JITTER, _AIM_JITTER, 2), 0.0)
        eye = aim + distance * np.array([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth),
                                         np.cos(tilt)])
        T_base_camera = look_at(eye, aim, roll=roll)
        plans.append(ViewPlan(T_base_camera, T_base_camera @ invert(T_flange_camera_guess),
                              float(np.degrees(tilt)), float(np.degrees(azimuth)),
                              float(np.degrees(roll)), float(distance)))
    return plans
