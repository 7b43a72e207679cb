"""Eye-in-hand calibration of the wrist camera, from capture to the calibrated camera.

The steps, each a function of its own module: capture the views (:mod:`.capture`), find
the board in each (:mod:`.board`; views without it are skipped and counted), the
intrinsics and distortion (:mod:`.intrinsics`), every ``calibrateHandEye`` method and
the choice among them by their consistency error (:mod:`.handeye`), and the joint
refinement (:mod:`.refine`).

Which one the calibration keeps, without ground truth: the refinement minimises pixel
error as if the robot's flange poses were exact. That holds when the views' corners fit
the robot's chain about as well as they fit free per-view board poses (the intrinsic
calibration, where only pixel noise remains): the refinement is kept when its RMS is
within ``MODEL_RATIO`` (2x) of the intrinsic RMS and below the chosen method's. A chain
RMS far above the pixel noise says the joint readings carry errors the pixels do not
explain (encoder noise, a kinematic error); a pixel fit would pour them into
``T_flange_camera``, so the closed-form result, which solves the rotation from the
rotations alone, is kept. No ground truth is read here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.calib.board import Board, BoardView, detect_board
from cell.calib.calfile import CameraCalibration
from cell.calib.capture import Capture, Progress, Rig, capture_views
from cell.calib.eyetohand import EyeToHandEstimate
from cell.calib.handeye import HandEyeData, HandEyeEstimate, compare_hand_eye
from cell.calib.intrinsics import Intrinsics, calibrate_intrinsics
from cell.calib.refine import EyeToHandRefinement, Refinement, refine_hand_eye
from cell.errors import CalibrationError

__all__ = ["MODEL_RATIO", "CalibrationSolution", "WristCalibration", "calibrate_wrist", "keep_refinement",
           "solve_wrist"]

MODEL_RATIO = 2.0  # largest chain RMS / intrinsic RMS at which the robot poses count as exact


@dataclass(frozen=True, eq=False)
class CalibrationSolution:
    """The array part of a calibration (:func:`solve_wrist`, ``solve_overhead``): the
    ``intrinsics``, every closed-form ``estimates`` of the camera's mount (hand-eye or
    eye-to-hand), the ``chosen`` method and the ``refinement`` started from its estimate."""

    intrinsics: Intrinsics
    estimates: tuple[HandEyeEstimate, ...] | tuple[EyeToHandEstimate, ...]
    chosen: str
    refinement: Refinement | EyeToHandRefinement

    @property
    def best(self) -> HandEyeEstimate | EyeToHandEstimate:
        """The chosen closed-form estimate."""
        return next(e for e in self.estimates if e.method == self.chosen)


@dataclass(frozen=True, eq=False)
class WristCalibration:
    """Everything a wrist calibration found: the ``capture``, the board ``detections`` (None
    where not found), the indices of the views ``used``, the ``intrinsics``, every hand-eye
    estimate, the ``chosen`` method, the ``refinement``, which one the camera holds
    (``kept``: ``"refined"`` or the chosen method) and the calibrated ``camera``."""

    capture: Capture
    detections: tuple[BoardView | None, ...]
    used: tuple[int, ...]
    intrinsics: Intrinsics
    hand_eye: tuple[HandEyeEstimate, ...]
    chosen: str
    refinement: Refinement
    kept: str
    camera: CameraCalibration

    @property
    def rejected(self) -> int:
        """Captured views in which the board was not found."""
        return len(self.detections) - len(self.used)


def solve_wrist(corners: np.ndarray, T_base_flange: np.ndarray, board: Board, *,
                image_size: tuple[int, int], terms: int) -> CalibrationSolution:
    """The array part of a wrist calibration: ``corners`` (N, M, 2) px and the flange poses
    ``T_base_flange`` (N, 4, 4) m of N views of ``board``, image (width, height) px,
    ``terms`` free distortion coefficients; the hand-eye estimates are ``T_flange_camera``'s."""
    intrinsics = calibrate_intrinsics(list(corners), board, image_size, terms=terms)
    data = HandEyeData(board.object_points(), np.asarray(corners, float), np.asarray(T_base_flange, float),
                       intrinsics.T_camera_board, intrinsics.K, intrinsics.dist)
    estimates, chosen = compare_hand_eye(data)
    start = next(e for e in estimates if e.method == chosen)
    refinement = refine_hand_eye(data, start.T_flange_camera, T_base_board=start.T_base_board)
    return CalibrationSolution(intrinsics, tuple(estimates), chosen, refinement)


def keep_refinement(intrinsics: Intrinsics, best: HandEyeEstimate, refinement: Refinement) -> bool:
    """True when the refinement is kept over the chosen closed-form ``best`` (see the
    module docstring): its RMS below ``best``'s and within ``MODEL_RATIO`` of the
    intrinsic RMS (px)."""
    return (refinement.rms_px < best.consistency_px
            and refinement.rms_px <= MODEL_RATIO * intrinsics.rms)


def calibrate_wrist(rig: Rig, settings: object, *, scenario: str, seed: int,
                    progress: Progress | None = None) -> WristCalibration:
    """Capture views with the wrist camera of ``rig`` and calibrate it by the
    ``[calibration]`` ``settings``; ``scenario`` and ``seed`` are recorded in the result.
    Raises ``CalibrationError`` when fewer than 3 views show the board."""
    board = Board.from_settings(settings)
    capture = capture_views(rig, settings, camera="wrist", progress=progress)
    detections = tuple(detect_board(v.image, board, first=settings.detector) for v in capture.views)
    used = tuple(i for i, d in enumerate(detections) if d is not None)
    if len(used) < 3:
        raise CalibrationError(f"wrist calibration: the board was found in {len(used)} of "
                               f"{len(detections)} views; at least 3 are needed")
    height, width = capture.views[0].image.shape[:2]
    corners = np.stack([detections[i].corners for i in used])
    flanges = np.stack([capture.views[i].T_base_flange for i in used])
    solution = solve_wrist(corners, flanges, board, image_size=(width, height),
                           terms=settings.distortion_terms)
    intrinsics, estimates, chosen, refinement = (solution.intrinsics, solution.estimates,
                                                 solution.chosen, solution.refinement)
    best = solution.best
    kept = "refined" if keep_refinement(intrinsics, best, refinement) else chosen
    pose = refinement.T_flange_camera if kept == "refined" else best.T_flange_camera
    camera = CameraCalibration(
        name="wrist", width=width, height=height, K=intrinsics.K, dist=intrinsics.dist,
        pose_name="T_flange_camera", pose=pose, rms=intrinsics.rms,
        method=f"{chosen}+refined" if kept == "refined" else chosen, scenario=scenario, seed=seed)
    return WristCalibration(capture, detections, used, intrinsics, estimates, chosen, refinement, kept,
                            camera)
