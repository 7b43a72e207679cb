"""Eye-to-hand calibration: ``cv2.calibrateRobotWorldHandEye`` (SHAH and LI), compared.

The overhead camera is fixed in the cell and the board rides on the flange
(``cell.sim.flange_board``). For every view i, with the flange pose ``T_base_flange[i]``
(forward kinematics of the joint readings) and the board pose ``T_camera_board[i]`` (from
the intrinsic calibration), two unknowns close the chain

    T_camera_board[i] = C^-1 T_base_flange[i] G,   C = T_base_camera,  G = T_flange_board,

an ``AX = ZB`` problem (Zhuang, Roth and Sudhakar, IEEE TRA 10(4), 1994). OpenCV's
robot-world/hand-eye solver is written for a camera on the gripper and a target fixed in
the world: ``T_camera_world[i] = T_camera_gripper T_gripper_base[i] T_base_world``. Fed
``T_board_camera[i]`` as ``world2cam`` and ``T_flange_base[i]`` as ``base2gripper``, its
"camera" is our board, its "world" our camera, its "gripper" our flange, and the chain
is ours: ``T_board_camera[i] = T_board_flange T_flange_base[i] T_base_camera``. Its
outputs ``base2world`` and ``gripper2cam`` are then ``T_camera_base`` and
``T_board_flange``. Methods: SHAH (M. Shah, "Solving the robot-world/hand-eye
calibration problem using the Kronecker product", J. Mech. Robot. 5(3), 2013) and LI
(A. Li, L. Wang and D. Wu, "Simultaneous robot-world and hand-eye calibration using
dual-quaternions and Kronecker product", Int. J. Phys. Sci. 5(10), 2010). Arrays passed to
OpenCV are made contiguous (a transposed view fails with "determinant(R) is null").

Choosing a method without ground truth, as for the wrist camera (:mod:`.handeye`): each
method's ``C`` implies one board mount per view, ``T_base_flange[i]^-1 C T_camera_board[i]``;
their average is the mount that ``C`` implies; projecting the board from it through every
view must land on the detected corners, and the lowest RMS miss (px, the *consistency*)
wins. It is the very cost the refinement (:func:`cell.calib.refine.refine_eye_to_hand`)
then minimises.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.calib.handeye import HandEyeData, check_turns, project
from cell.calib.intrinsics import one_thread
from cell.calib.transforms import invert, make_transform, mean_transform
from cell.errors import CalibrationError

__all__ = [
    "ROBOT_WORLD_METHODS",
    "EyeToHandEstimate",
    "board_on_flange",
    "compare_eye_to_hand",
    "consistency_fixed",
    "reprojection_fixed",
    "solve_eye_to_hand",
]

ROBOT_WORLD_METHODS = {
    "SHAH": cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH,
    "LI": cv2.CALIB_ROBOT_WORLD_HAND_EYE_LI,
}


@dataclass(frozen=True, eq=False)
class EyeToHandEstimate:
    """One eye-to-hand solution: ``method``, ``T_base_camera`` (4x4, m), the board mount
    it implies ``T_flange_board`` (4x4, m; the average over the views) and its consistency
    error ``consistency_px`` (RMS, px)."""

    method: str
    T_base_camera: np.ndarray
    T_flange_board: np.ndarray
    consistency_px: float


def _contiguous(Ts: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    return ([np.ascontiguousarray(T[:3, :3]) for T in Ts], [np.ascontiguousarray(T[:3, 3]) for T in Ts])


def solve_eye_to_hand(data: HandEyeData, *, method: str) -> tuple[np.ndarray, np.ndarray]:
    """(``T_base_camera``, ``T_flange_board``), both 4x4 in metres, by
    ``cv2.calibrateRobotWorldHandEye`` with ``method`` (a key of ``ROBOT_WORLD_METHODS``),
    passed by keyword, on the views of a fixed camera and a board on the flange (see the
    module docstring for the mapping of frames)."""
    if method not in ROBOT_WORLD_METHODS:
        raise CalibrationError(f"eye-to-hand: unknown method {method!r}; valid: "
                               f"{', '.join(ROBOT_WORLD_METHODS)}")
    R_world2cam, t_world2cam = _contiguous(invert(data.T_camera_board))  # T_board_camera
    R_base2gripper, t_base2gripper = _contiguous(invert(data.T_base_flange))  # T_flange_base
    try:
        with one_thread():
            R_camera_base, t_camera_base, R_board_flange, t_board_flange = cv2.calibrateRobotWorldHandEye(
                R_world2cam, t_world2cam, R_base2gripper, t_base2gripper,
                method=ROBOT_WORLD_METHODS[method])
    except cv2.error as exc:  # a degenerate set of views
        raise CalibrationError(f"eye-to-hand: method {method} failed in OpenCV "
                               f"({str(exc).strip().splitlines()[-1]})") from None
    T_camera_base = make_transform(np.asarray(R_camera_base, np.float64),
                                   np.asarray(t_camera_base, np.float64))
    T_board_flange = make_transform(np.asarray(R_board_flange, np.float64),
                                    np.asarray(t_board_flange, np.float64))
    if not (np.isfinite(T_camera_base).all() and np.isfinite(T_board_flange).all()):
        raise CalibrationError(f"eye-to-hand: method {method} gave a non-finite result (too little "
                               "rotation between the views?)")
    return invert(T_camera_base), invert(T_board_flange)


def board_on_flange(data: HandEyeData, T_base_camera: np.ndarray) -> np.ndarray:
    """The board mount seen by each view (N, 4, 4), metres:
    ``T_base_flange[i]^-1 @ T_base_camera @ T_camera_board[i]``."""
    return invert(data.T_base_flange) @ T_base_camera @ data.T_camera_board


def reprojection_fixed(data: HandEyeData, T_base_camera: np.ndarray, T_flange_board: np.ndarray, *,
                       K: np.ndarray | None = None, dist: np.ndarray | None = None) -> np.ndarray:
    """Pixels (N, M, 2) of the board corners on the flange seen by the fixed camera in each
    view: ``T_camera_board = T_base_camera^-1 T_base_flange[i] T_flange_board``, projected
    through ``K`` and ``dist`` (default: the data's)."""
    T_camera_board = invert(T_base_camera) @ data.T_base_flange @ T_flange_board
    P = np.einsum("nij,mj->nmi", T_camera_board[:, :3, :3], data.object_points)
    return project(P + T_camera_board[:, None, :3, 3], data.K if K is None else K,
                   data.dist if dist is None else dist)


def consistency_fixed(data: HandEyeData, T_base_camera: np.ndarray) -> tuple[np.ndarray, float]:
    """(the average board mount ``T_flange_board`` that ``T_base_camera`` implies, and the
    RMS distance in px between the corners projected from it and the detected ones)."""
    T_flange_board = mean_transform(board_on_flange(data, T_base_camera))
    miss = reprojection_fixed(data, T_base_camera, T_flange_board) - data.corners
    return T_flange_board, float(np.sqrt(np.mean(np.sum(miss**2, axis=-1))))


def compare_eye_to_hand(data: HandEyeData) -> tuple[tuple[EyeToHandEstimate, ...], str]:
    """Every method's estimate and the name of the one with the lowest consistency error.

    A method whose result is not finite is left out; if all fail, ``CalibrationError``.
    """
    check_turns(data.T_camera_board, "eye-to-hand", "calibration.overhead_tilt")
    estimates = []
    for name in ROBOT_WORLD_METHODS:
        try:
            T_base_camera, _ = solve_eye_to_hand(data, method=name)
        except CalibrationError:
            continue
        T_flange_board, rms = consistency_fixed(data, T_base_camera)
        if np.isfinite(rms):
            estimates.append(EyeToHandEstimate(name, T_base_camera, T_flange_board, rms))
    if not estimates:
        raise CalibrationError("eye-to-hand: no method gave a finite result")
    best = min(estimates, key=lambda e: e.consistency_px)
    return tuple(estimates), best.method
