"""Eye-in-hand calibration: ``cv2.calibrateHandEye`` with all five methods, compared.

The wrist camera rides on the flange: for every view i, with the flange pose
``T_base_flange[i]`` (forward kinematics of the joint readings) and the board pose
``T_camera_board[i]`` (from the intrinsic calibration), the unknown ``X = T_flange_camera``
satisfies ``A X = X B`` between any two views (Shiu and Ahmad, IEEE TRA 5(1), 1989), and
the board's pose in the base frame ``T_base_board = T_base_flange[i] X T_camera_board[i]``
is the same in every view. OpenCV solves ``AX = XB`` by TSAI (Tsai and Lenz, IEEE TRA 5(3),
1989), PARK (Park and Martin, IEEE TRA 10(5), 1994), HORAUD (Horaud and Dornaika, IJRR
14(3), 1995), ANDREFF (Andreff, Horaud and Espiau, 3DIM 1999) and DANIILIDIS (dual
quaternions, IJRR 18(3), 1999).

Choosing a method without ground truth: each method's ``X`` gives one board pose per
view; their average is the board pose that ``X`` implies. Projecting the board from that
one pose through each view's flange pose and ``X`` must land on the detected corners; the
RMS of the misses (px) is the method's *consistency error*, and the lowest wins. It is
the very cost the refinement (:mod:`cell.calib.refine`) then minimises.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.calib.intrinsics import one_thread
from cell.calib.transforms import invert, make_transform, mean_transform
from cell.errors import CalibrationError

__all__ = [
    "HAND_EYE_METHODS",
    "HandEyeData",
    "HandEyeEstimate",
    "board_in_base",
    "compare_hand_eye",
    "consistency",
    "project",
    "reprojection",
    "check_turns",
    "second_turn_deg",
    "solve_hand_eye",
]

MIN_SECOND_TURN_DEG = 1.0  # the views must turn this much (RMS) about a second axis

HAND_EYE_METHODS = {
    "TSAI": cv2.CALIB_HAND_EYE_TSAI,
    "PARK": cv2.CALIB_HAND_EYE_PARK,
    "HORAUD": cv2.CALIB_HAND_EYE_HORAUD,
    "ANDREFF": cv2.CALIB_HAND_EYE_ANDREFF,
    "DANIILIDIS": cv2.CALIB_HAND_EYE_DANIILIDIS,
}


@dataclass(frozen=True, eq=False)
class HandEyeData:
    """The views of a hand-eye calibration: a camera on the flange and a board in the
    cell (eye-in-hand, here), or a fixed camera and a board on the flange (eye-to-hand,
    :mod:`cell.calib.eyetohand`).

    ``object_points`` (M, 3) board corners in the board frame (m); ``corners`` (N, M, 2)
    their detections (px); ``T_base_flange`` (N, 4, 4) from the joint readings;
    ``T_camera_board`` (N, 4, 4) from the intrinsic calibration; ``K`` (3x3) and ``dist``
    (5,) the calibrated intrinsics.
    """

    object_points: np.ndarray
    corners: np.ndarray
    T_base_flange: np.ndarray
    T_camera_board: np.ndarray
    K: np.ndarray
    dist: np.ndarray

    def __post_init__(self) -> None:
        n, m = len(self.T_base_flange), len(self.object_points)
        shapes = {"corners": (self.corners, (n, m, 2)), "T_camera_board": (self.T_camera_board, (n, 4, 4)),
                  "T_base_flange": (self.T_base_flange, (n, 4, 4))}
        for name, (value, shape) in shapes.items():
            if np.shape(value) != shape:
                raise CalibrationError(f"hand-eye data: '{name}' has shape {np.shape(value)}, "
                                       f"expected {shape}")
        if n < 3:
            raise CalibrationError(f"hand-eye data: need at least 3 views, got {n}")


@dataclass(frozen=True, eq=False)
class HandEyeEstimate:
    """One hand-eye solution: ``method``, ``T_flange_camera`` (4x4, m), the board pose it
    implies ``T_base_board`` (4x4, m) and its consistency error ``consistency_px`` (RMS, px)."""

    method: str
    T_flange_camera: np.ndarray
    T_base_board: np.ndarray
    consistency_px: float


def project(points_camera: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Pixels (..., 2) of camera-frame points (..., 3) through the pinhole and the
    Brown-Conrady distortion (k1, k2, p1, p2, k3), as ``cv2.projectPoints`` computes them."""
    x = points_camera[..., 0] / points_camera[..., 2]
    y = points_camera[..., 1] / points_camera[..., 2]
    k1, k2, p1, p2, k3 = dist
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=-1)


def board_in_base(data: HandEyeData, T_flange_camera: np.ndarray) -> np.ndarray:
    """The board pose in the base frame seen by each view (N, 4, 4):
    ``T_base_flange[i] @ T_flange_camera @ T_camera_board[i]``."""
    return data.T_base_flange @ T_flange_camera @ data.T_camera_board


def reprojection(data: HandEyeData, T_flange_camera: np.ndarray, T_base_board: np.ndarray) -> np.ndarray:
    """Pixels (N, M, 2) of the board corners at ``T_base_board`` seen through each view:
    ``T_camera_board = T_flange_camera^-1 T_base_flange[i]^-1 T_base_board``."""
    T_camera_board = invert(T_flange_camera) @ invert(data.T_base_flange) @ T_base_board
    P = np.einsum("nij,mj->nmi", T_camera_board[:, :3, :3], data.object_points)
    return project(P + T_camera_board[:, None, :3, 3], data.K, data.dist)


def consistency(data: HandEyeData, T_flange_camera: np.ndarray) -> tuple[np.ndarray, float]:
    """(the average board pose ``T_base_board`` that ``T_flange_camera`` implies, and the
    RMS distance in px between the corners projected from it and the detected ones)."""
    T_base_board = mean_transform(board_in_base(data, T_flange_camera))
    miss = reprojection(data, T_flange_camera, T_base_board) - data.corners
    return T_base_board, float(np.sqrt(np.mean(np.sum(miss**2, axis=-1))))


def second_turn_deg(T: np.ndarray) -> float:
    """How much the views turned about a second axis (degrees, RMS): the second singular
    value of the rotation vectors of every pose ``T`` (N, 4, 4) relative to the first,
    over the square root of their count. Zero when every view turns about one axis (a
    tool that only spins about its own axis, say): hand-eye calibration then has no
    unique answer (Tsai & Lenz, IEEE TRA 5(3), 1989: two non-parallel rotation axes).
    The board's poses in the camera turn as the flange does, and come from the images,
    not the joint readings (whose noise alone would fake a few degrees of turn)."""
    from scipy.spatial.transform import Rotation

    R = np.asarray(T, dtype=np.float64)[:, :3, :3]
    if len(R) < 3:
        return 0.0
    turns = Rotation.from_matrix(np.einsum("ji,njk->nik", R[0], R[1:])).as_rotvec()
    s = np.linalg.svd(turns, compute_uv=False)
    return float(np.degrees(s[1] / np.sqrt(len(turns))))


def check_turns(T_camera_board: np.ndarray, what: str, key: str) -> None:
    """A ``CalibrationError`` naming ``what`` and the scenario ``key`` that tilts the views,
    when they turn about one axis only (:func:`second_turn_deg` of the board's poses in the
    camera, (N, 4, 4))."""
    turn = second_turn_deg(T_camera_board)
    if not turn >= MIN_SECOND_TURN_DEG:
        raise CalibrationError(
            f"{what}: the views turn about one axis only ({turn:.2f} deg RMS about a second "
            f"axis, at least {MIN_SECOND_TURN_DEG:g} needed): the calibration has no unique "
            f"answer; tilt the views more ({key})")


def solve_hand_eye(data: HandEyeData, *, method: str) -> np.ndarray:
    """``T_flange_camera`` (4x4, m) by ``cv2.calibrateHandEye`` with ``method`` (a key of
    ``HAND_EYE_METHODS``), passed by keyword (positionally it would land in an output slot)."""
    if method not in HAND_EYE_METHODS:
        raise CalibrationError(f"hand-eye: unknown method {method!r}; valid: {', '.join(HAND_EYE_METHODS)}")
    A, B = data.T_base_flange, data.T_camera_board
    try:
        with one_thread():
            R, t = cv2.calibrateHandEye(
                [np.ascontiguousarray(T[:3, :3]) for T in A], [np.ascontiguousarray(T[:3, 3]) for T in A],
                [np.ascontiguousarray(T[:3, :3]) for T in B], [np.ascontiguousarray(T[:3, 3]) for T in B],
                method=HAND_EYE_METHODS[method])
    except cv2.error as exc:  # a degenerate set of views: "determinant(R) is null", ...
        raise CalibrationError(f"hand-eye: method {method} failed in OpenCV "
                               f"({str(exc).strip().splitlines()[-1]})") from None
    X = make_transform(np.asarray(R, dtype=np.float64), np.asarray(t, dtype=np.float64))
    if np.array_equal(X, np.eye(4)):  # OpenCV logs "Hand-eye calibration failed!" and
        # returns its untouched start (Tsai with three views, say), which no real mount is
        raise CalibrationError(f"hand-eye: method {method} failed in OpenCV (no solution from "
                               f"these {len(A)} views)")
    if not np.isfinite(X).all():
        raise CalibrationError(f"hand-eye: method {method} gave a non-finite result (too little "
                               "rotation between the views?)")
    return X


def compare_hand_eye(data: HandEyeData) -> tuple[tuple[HandEyeEstimate, ...], str]:
    """Every method's estimate and the name of the one with the lowest consistency error.

    Views that turn about one axis only (:func:`second_turn_deg` under
    ``MIN_SECOND_TURN_DEG``) are a ``CalibrationError``: the problem has no unique answer.
    A method whose result is not finite is left out; if all fail, ``CalibrationError``.
    """
    check_turns(data.T_camera_board, "hand-eye", "calibration.max_tilt")
    estimates = []
    for name in HAND_EYE_METHODS:
        try:
            X = solve_hand_eye(data, method=name)
        except CalibrationError:
            continue
        T_base_board, rms = consistency(data, X)
        if np.isfinite(rms):
            estimates.append(HandEyeEstimate(name, X, T_base_board, rms))
    if not estimates:
        raise CalibrationError("hand-eye: no method gave a finite result")
    best = min(estimates, key=lambda e: e.consistency_px)
    return tuple(estimates), best.method
