"""Intrinsics and lens distortion from checkerboard views: ``cv2.calibrateCamera``.

Zhang's method (Z. Zhang, "A flexible new technique for camera calibration", PAMI 22(11),
2000): a closed-form start from the views' plane-to-image homographies, then
Levenberg-Marquardt over K, the Brown-Conrady distortion (k1, k2, p1, p2, k3) and each
view's board pose, minimising the reprojection error. ``terms`` picks which distortion
coefficients are free (the others stay 0): a model richer than the lens only adds noise.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import cv2
import numpy as np

from cell.calib.board import Board
from cell.calib.transforms import transform_from_rvec
from cell.errors import CalibrationError

__all__ = ["DISTORTION_FLAGS", "Intrinsics", "calibrate_intrinsics", "one_thread"]

DISTORTION_FLAGS = {
    0: cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST,
    2: cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST,
    4: cv2.CALIB_FIX_K3,
    5: 0,
}
_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)


@contextmanager
def one_thread() -> Iterator[None]:
    """Run OpenCV on one thread meanwhile: its parallel reductions (``calibrateCamera``'s
    among them) sum in a varying order, so results would differ in the last digits from
    run to run; one seed must give one result, bit for bit."""
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(threads)


@dataclass(frozen=True, eq=False)
class Intrinsics:
    """The result of an intrinsic calibration.

    ``K`` (3x3, pixels), ``dist`` (5,: k1, k2, p1, p2, k3), ``rms`` the reprojection RMS
    over all corners (px), ``view_rms`` (N,) per view (px), ``T_camera_board`` (N, 4, 4)
    each view's board pose (metres).
    """

    K: np.ndarray
    dist: np.ndarray
    rms: float
    view_rms: np.ndarray
    T_camera_board: np.ndarray


def calibrate_intrinsics(corners: list[np.ndarray], board: Board, image_size: tuple[int, int], *,
                         terms: int = 4) -> Intrinsics:
    """Calibrate from the corners (each (M, 2) px, in board order) of N >= 3 views.

    ``image_size`` is (width, height) in pixels; ``terms`` the number of free distortion
    coefficients (0, 2, 4 or 5). Raises ``CalibrationError`` for too few views, corners of
    the wrong shape, or a result that is not finite.
    """
    if terms not in DISTORTION_FLAGS:
        raise CalibrationError(f"calibrate_intrinsics: terms must be one of "
                               f"{sorted(DISTORTION_FLAGS)}, got {terms}")
    if len(corners) < 3:
        raise CalibrationError(f"calibrate_intrinsics: need at least 3 views of the board, got "
                               f"{len(corners)}")
    obj = board.object_points().astype(np.float32)
    img = []
    for k, c in enumerate(corners):
        c = np.asarray(c, dtype=np.float32)
        if c.shape != (board.count, 2):
            raise CalibrationError(f"calibrate_intrinsics: view {k} has corners of shape {c.shape}, "
                                   f"expected ({board.count}, 2)")
        img.append(c.reshape(-1, 1, 2))
    width, height = image_size
    with one_thread():
        result = cv2.calibrateCameraExtended(
            [obj] * len(img), img, (int(width), int(height)), None, None,
            flags=DISTORTION_FLAGS[terms], criteria=_CRITERIA)
    rms, K, dist, rvecs, tvecs, _, _, per_view = result
    K, dist = np.asarray(K, dtype=np.float64), np.asarray(dist, dtype=np.float64).reshape(-1)[:5]
    if not (np.isfinite(K).all() and np.isfinite(dist).all() and np.isfinite(rms)):
        raise CalibrationError("calibrate_intrinsics: the solution is not finite (degenerate views: "
                               "the board must be seen from several tilts)")
    poses = np.stack([transform_from_rvec(r, t) for r, t in zip(rvecs, tvecs, strict=True)])
    return Intrinsics(K=K, dist=dist, rms=float(rms), view_rms=np.asarray(per_view, float).reshape(-1),
                      T_camera_board=poses)
