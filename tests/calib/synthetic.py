"""Synthetic calibration data: exact projections of a board through a known camera and mount."""

from __future__ import annotations

import cv2
import numpy as np

from cell.calib.board import Board
from cell.calib.calfile import CalibrationFile, CameraCalibration
from cell.calib.handeye import project
from cell.calib.planning import plan_views
from cell.calib.settings import CalibrationSettings
from cell.calib.transforms import invert, make_transform, transform_from_rvec

BOARD = Board((8, 5), 0.025)
K_TRUE = np.array([[515.0, 0.0, 321.0], [0.0, 512.0, 238.0], [0.0, 0.0, 1.0]])
SIZE = (640, 480)
# a mount a little off the nominal one: turned by about 1.5 deg, shifted by a few mm
X_TRUE = make_transform(transform_from_rvec([0.012, -0.02, 0.015], np.zeros(3))[:3, :3],
                        [0.003, 0.066, 0.028])
B_TRUE = make_transform(transform_from_rvec([0.0, 0.0, 0.05], np.zeros(3))[:3, :3], [0.41, -0.02, 0.004])


def views(n: int, *, seed: int, dist: np.ndarray | None = None, noise_px: float = 0.0) -> dict:
    """``n`` views of the board at ``B_TRUE`` through ``X_TRUE`` and ``K_TRUE`` from the
    calibration's own view plan: flange poses (n, 4, 4), corners (n, M, 2) px, and the
    true board poses in the camera (n, 4, 4)."""
    rng = np.random.default_rng(seed)
    dist = np.zeros(5) if dist is None else np.asarray(dist, float)
    settings = CalibrationSettings(board_position=tuple(B_TRUE[:3, 3] + [0.0875, 0.05, 0.0]))
    plans = plan_views(settings, rng, count=n)
    obj = BOARD.object_points()
    flanges, corners, poses = [], [], []
    for plan in plans:
        T_base_flange = plan.T_base_camera @ invert(X_TRUE)
        T_camera_board = invert(plan.T_base_camera) @ B_TRUE
        P = obj @ T_camera_board[:3, :3].T + T_camera_board[:3, 3]
        pixels = project(P, K_TRUE, dist) + rng.normal(0.0, noise_px, (len(obj), 2))
        flanges.append(T_base_flange)
        corners.append(pixels)
        poses.append(T_camera_board)
    return {"T_base_flange": np.array(flanges), "corners": np.array(corners),
            "T_camera_board": np.array(poses)}


# Eye-to-hand: a fixed camera 0.48 m above the table looking down, turned a little off the
# nominal; a 15 mm board on the flange, 65 mm to the side of the tool axis
PLATE = Board((8, 5), 0.015)
K_FIXED = np.array([[659.0, 0.0, 320.2], [0.0, 660.1, 239.1], [0.0, 0.0, 1.0]])
C_TRUE = make_transform(
    np.diag([1.0, -1.0, -1.0]) @ transform_from_rvec([0.004, -0.006, 0.01], np.zeros(3))[:3, :3],
    [0.002, 0.451, 0.479])
G_TRUE = make_transform(transform_from_rvec([0.0, -np.pi / 2, 0.0], np.zeros(3))[:3, :3] @
                        transform_from_rvec([0.01, 0.0, -0.02], np.zeros(3))[:3, :3], [-0.065, -0.053, 0.036])


def fixed_views(n: int, *, seed: int, dist: np.ndarray | None = None, noise_px: float = 0.0) -> dict:
    """``n`` views of the board on the flange (``G_TRUE``) by the fixed camera (``C_TRUE``,
    ``K_FIXED``): the board 0.22-0.29 m in front of the camera, tilted 8-40 deg about a
    random axis, turned up to 60 deg about its normal, off the axis by up to 3 cm. Returns
    flange poses (n, 4, 4), corners (n, M, 2) px and the true board poses in the camera."""
    rng = np.random.default_rng(seed)
    dist = np.zeros(5) if dist is None else np.asarray(dist, float)
    obj = PLATE.object_points()
    centre = obj.mean(axis=0)
    flanges, corners, poses = [], [], []
    for _ in range(n):
        phi = rng.uniform(0, 2 * np.pi)
        tilt = np.radians(rng.uniform(8, 40))
        R = (transform_from_rvec(tilt * np.array([np.cos(phi), np.sin(phi), 0.0]), np.zeros(3))[:3, :3]
             @ transform_from_rvec([0.0, 0.0, np.radians(rng.uniform(-60, 60))], np.zeros(3))[:3, :3])
        at = np.array([rng.uniform(-0.03, 0.03), rng.uniform(-0.01, 0.01), rng.uniform(0.22, 0.29)])
        T_camera_board = make_transform(R, at - R @ centre)
        T_base_flange = C_TRUE @ T_camera_board @ invert(G_TRUE)
        P = obj @ T_camera_board[:3, :3].T + T_camera_board[:3, 3]
        pixels = project(P, K_FIXED, dist) + rng.normal(0.0, noise_px, (len(obj), 2))
        flanges.append(T_base_flange)
        corners.append(pixels)
        poses.append(T_camera_board)
    return {"T_base_flange": np.array(flanges), "corners": np.array(corners),
            "T_camera_board": np.array(poses)}


def board_image(H: np.ndarray, size: tuple[int, int] = SIZE, *, scale: int = 8) -> np.ndarray:
    """A grey image of the board (white margin one square wide, black square at the
    origin's outer diagonal), drawn through the board-to-image homography ``H`` (from
    board metres) with ``scale`` x supersampling and area averaging."""
    nx, ny = BOARD.inner_corners
    s = BOARD.square
    px = 40  # texture pixels per square
    tex = np.full(((ny + 3) * px, (nx + 3) * px), 255, np.uint8)
    for i in range(nx + 1):
        for j in range(ny + 1):
            if (i + j) % 2 == 0:
                tex[(j + 1) * px:(j + 2) * px, (i + 1) * px:(i + 2) * px] = 0
    # texture pixel index u -> board metres: square (i, j) spans texture pixels from
    # (i + 1) px (edge at u = (i + 1) px - 0.5) and board x from (i - 1) s
    off = 0.5 * s / px - 2 * s
    T_board_tex = np.array([[s / px, 0, off], [0, s / px, off], [0, 0, 1.0]])
    # image pixel index x -> supersampled index k = scale (x + 0.5) - 0.5
    c = 0.5 * scale - 0.5
    S = np.array([[scale, 0, c], [0, scale, c], [0, 0, 1.0]])
    big = cv2.warpPerspective(tex, S @ H @ T_board_tex, (size[0] * scale, size[1] * scale),
                              flags=cv2.INTER_LINEAR, borderValue=128)
    return cv2.resize(big, size, interpolation=cv2.INTER_AREA)


def calibration_entry(**changes) -> CameraCalibration:
    """A valid wrist calibration entry, with ``changes`` applied."""
    fields = {"name": "wrist", "width": 640, "height": 480, "K": K_TRUE, "dist": np.zeros(5),
              "pose_name": "T_flange_camera", "pose": X_TRUE, "rms": 0.04, "method": "PARK+refined",
              "scenario": "test", "seed": 7}
    fields.update(changes)
    return CameraCalibration(**fields)


def calibration_file() -> CalibrationFile:
    return CalibrationFile((calibration_entry(),))
