"""Eye-to-hand calibration of the overhead camera, from capture to the calibrated camera.

The overhead camera is fixed above the pick zone; the arm carries a checkerboard plate on
the tool (``cell.sim.flange_board``: on the side of the tool housing, face up when the
tool is level) through ``calibration.poses`` poses in front of it. The steps:

1. **Capture** (:func:`capture_overhead`): the poses come from
   ``cell.sim.board_poses.propose_flange_board_poses`` (seeded from the calibration's
   generator; planned from the cell's drawings and the lens's nominal field of view, never
   the true camera), each collision-free and joined to the one before and to the start by a
   collision-free joint-space line. The arm drives through them on its servos, holds still,
   and at each the overhead camera takes its image and the controller reads the joints; the
   flange pose is pinocchio's forward kinematics of the readings.
2. **Corners** as for the wrist camera (:func:`cell.calib.board.detect_board`); views
   without the board are skipped and counted.
3. **Intrinsics and distortion** from the same views (``cv2.calibrateCamera``; k1 and k2
   by default, ``calibration.overhead_distortion_terms``).
4. **Eye-to-hand** by ``cv2.calibrateRobotWorldHandEye``, SHAH and LI
   (:mod:`.eyetohand`), the more consistent chosen without ground truth.
5. **Refinement** (:func:`cell.calib.refine.refine_eye_to_hand`): ``T_base_camera`` and
   ``T_flange_board`` jointly, and the intrinsics with them when
   ``calibration.refine_intrinsics`` (default), minimising the reprojection error of every
   corner in every view. Kept by the wrist camera's rule
   (:func:`cell.calib.wrist.keep_refinement`): when the chain RMS is within twice the
   intrinsic RMS and below the chosen method's; otherwise the chosen closed form and the
   intrinsic calibration's ``K`` and ``dist`` are what the file holds.

No ground truth is read here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell.calib.board import Board, BoardView, detect_board
from cell.calib.calfile import CameraCalibration
from cell.calib.capture import Capture, CapturedView, Progress, Rig
from cell.calib.eyetohand import EyeToHandEstimate, compare_eye_to_hand
from cell.calib.handeye import HandEyeData
from cell.calib.intrinsics import Intrinsics, calibrate_intrinsics
from cell.calib.refine import EyeToHandRefinement, refine_eye_to_hand
from cell.calib.wrist import CalibrationSolution, keep_refinement
from cell.errors import CalibrationError, IKError, MotionError

__all__ = ["CAMERA", "OverheadCalibration", "calibrate_overhead", "capture_overhead", "solve_overhead"]

CAMERA = "overhead"


@dataclass(frozen=True, eq=False)
class OverheadCalibration:
    """Everything an overhead calibration found: the ``capture``, the board ``detections``
    (None where not found), the indices of the views ``used``, the ``intrinsics``, every
    eye-to-hand estimate (``hand_eye``), the ``chosen`` method, the ``refinement``, which
    one the camera holds (``kept``: ``"refined"`` or the chosen method) and the calibrated
    ``camera`` (``T_base_camera``)."""

    capture: Capture
    detections: tuple[BoardView | None, ...]
    used: tuple[int, ...]
    intrinsics: Intrinsics
    hand_eye: tuple[EyeToHandEstimate, ...]
    chosen: str
    refinement: EyeToHandRefinement
    kept: str
    camera: CameraCalibration

    @property
    def rejected(self) -> int:
        """Captured views in which the board was not found."""
        return len(self.detections) - len(self.used)


def capture_overhead(rig: Rig, settings: object, *, lens: object,
                     progress: Progress | None = None) -> Capture:
    """Drive the plate on the tool through ``settings.poses`` poses in front of the overhead
    camera and take a view at each (see the module docstring).

    ``lens`` is the scenario's ``[camera]`` section: the overhead lens's nominal ``fovy``
    (deg) and the image ``width`` x ``height`` (px), which the pose planner aims with.
    A pose the servos cannot reach is skipped and counted as ``blocked``; fewer than 3
    views, or a planner that finds too few poses, is a ``CalibrationError``.
    """
    from cell.sim.board_poses import propose_flange_board_poses

    want = int(settings.poses)
    q_start = rig.driver.joint_positions()
    try:
        targets = propose_flange_board_poses(
            want, seed=int(rig.rng.integers(2**31 - 1)), fovy=float(lens.fovy), width=int(lens.width),
            height=int(lens.height), start=q_start, ik=rig.ik, tilt=tuple(settings.overhead_tilt))
    except IKError as exc:
        raise CalibrationError(f"overhead calibration: cannot plan {want} views of the tool plate "
                               f"(calibration.poses, calibration.overhead_tilt): {exc}") from None
    rig.driver.sync()
    views: list[CapturedView] = []
    blocked = 0
    for k, q in enumerate(targets):
        try:
            rig.driver.move(q, what=f"overhead calibration view {k + 1}")
        except MotionError:
            blocked += 1
            rig.driver.sync()
            continue
        image, q_read = rig.hold_and_look(CAMERA)
        views.append(CapturedView(image, q_read, rig.kin.pose(q_read, "flange"), None))
        if progress is not None:
            progress(len(views), want, "overhead camera, plate on the tool")
    try:
        rig.driver.move(q_start, what="the start pose after the overhead views")
    except MotionError as exc:
        raise CalibrationError(f"overhead calibration: {exc}") from None
    if len(views) < 3:
        raise CalibrationError(f"overhead calibration: only {len(views)} of {want} planned views were "
                               f"reached ({blocked} blocked)")
    return Capture(CAMERA, tuple(views), 0, blocked)


def solve_overhead(corners: np.ndarray, T_base_flange: np.ndarray, board: Board, *,
                   image_size: tuple[int, int], terms: int, free_intrinsics: bool
                   ) -> CalibrationSolution:
    """The array part of an overhead calibration: ``corners`` (N, M, 2) px and the flange
    poses ``T_base_flange`` (N, 4, 4) m of N views of ``board`` on the flange, image
    (width, height) px, ``terms`` free distortion coefficients, whether the refinement frees
    the intrinsics; the eye-to-hand estimates are ``T_base_camera``'s."""
    intrinsics = calibrate_intrinsics(list(corners), board, image_size, terms=terms)
    data = HandEyeData(board.object_points(), np.asarray(corners, float), np.asarray(T_base_flange, float),
                       intrinsics.T_camera_board, intrinsics.K, intrinsics.dist)
    estimates, chosen = compare_eye_to_hand(data)
    start = next(e for e in estimates if e.method == chosen)
    refinement = refine_eye_to_hand(data, start.T_base_camera, T_flange_board=start.T_flange_board,
                                    free_intrinsics=free_intrinsics, terms=terms)
    return CalibrationSolution(intrinsics, tuple(estimates), chosen, refinement)


def calibrate_overhead(rig: Rig, settings: object, *, lens: object, scenario: str, seed: int,
                       progress: Progress | None = None) -> OverheadCalibration:
    """Capture views of the plate on the tool of ``rig``'s arm with the overhead camera and
    calibrate the camera by the ``[calibration]`` ``settings`` (``lens``: the scenario's
    ``[camera]`` section); ``scenario`` and ``seed`` are recorded in the result. Raises
    ``CalibrationError`` when fewer than 3 views show the plate."""
    if not getattr(rig.world, "has_flange_board", False):
        raise CalibrationError("overhead calibration: the arm carries no checkerboard plate (build "
                               "the world with flange_board=True)")
    board = Board.on_tool_from_settings(settings)
    capture = capture_overhead(rig, settings, lens=lens, progress=progress)
    detections = tuple(detect_board(v.image, board, first=settings.detector) for v in capture.views)
    used = tuple(i for i, d in enumerate(detections) if d is not None)
    if len(used) < 3:
        raise CalibrationError(f"overhead calibration: the tool plate was found in {len(used)} of "
                               f"{len(detections)} views; at least 3 are needed")
    height, width = capture.views[0].image.shape[:2]
    corners = np.stack([detections[i].corners for i in used])
    flanges = np.stack([capture.views[i].T_base_flange for i in used])
    solution = solve_overhead(corners, flanges, board, image_size=(width, height),
                              terms=settings.overhead_distortion_terms,
                              free_intrinsics=settings.refine_intrinsics)
    intrinsics, estimates, chosen, refinement = (solution.intrinsics, solution.estimates,
                                                 solution.chosen, solution.refinement)
    best = solution.best
    kept = "refined" if keep_refinement(intrinsics, best, refinement) else chosen
    if kept == "refined":  # the RMS of the intrinsics held: the refinement's when it freed them
        K, dist, pose = refinement.K, refinement.dist, refinement.T_base_camera
        rms = refinement.rms_px if refinement.free_intrinsics else intrinsics.rms
    else:
        K, dist, pose, rms = intrinsics.K, intrinsics.dist, best.T_base_camera, intrinsics.rms
    camera = CameraCalibration(
        name=CAMERA, width=width, height=height, K=K, dist=dist, pose_name="T_base_camera", pose=pose,
        rms=rms, method=f"{chosen}+refined" if kept == "refined" else chosen, scenario=scenario, seed=seed)
    return OverheadCalibration(capture, detections, used, intrinsics, estimates, chosen, refinement, kept,
                               camera)
