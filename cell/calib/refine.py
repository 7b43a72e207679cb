"""Joint refinement of the hand-eye transform and the board pose by nonlinear least squares.

None of the closed-form ``AX = XB`` solvers looks at pixels: they fit the views' rotations
and translations, weighting them as they come. The refinement minimises what a camera
actually measures, the reprojection error of every corner in every view (px), over the
12 parameters of ``X = T_flange_camera`` and ``B = T_base_board`` at once:

    r_ij = project(K, dist, X^-1 T_base_flange[i]^-1 B P_j) - c_ij

with the intrinsics fixed (a bundle adjustment of the hand-eye chain; cf. Strobl and
Hirzinger, "Optimal hand-eye calibration", IROS 2006, and Tabb and Ahmad Yousef, MVA 28,
2017, who minimise reprojection error rather than a pose residual). Both unknowns are
perturbed on the right/left by axis-angle increments from the start (so no angle
wraps), solved with ``scipy.optimize.least_squares`` (trust-region reflective,
Jacobian by finite differences, parameters scaled by the Jacobian's columns).

The eye-to-hand refinement (:func:`refine_eye_to_hand`) does the same for a fixed camera
and a board on the flange: ``C = T_base_camera`` and ``G = T_flange_board`` in

    r_ij = project(K, dist, C^-1 T_base_flange[i] G P_j) - c_ij,

and, on request, frees the intrinsics too (fx, fy, cx, cy and the distortion terms that
the intrinsic calibration estimated). The intrinsic calibration fits every view its own
board pose, so the principal point trades against those poses; the robot's chain ties the
views together, which pins the principal point (the camera's rotation error follows it)
when the joint readings are exact. Whether it is used is a setting
(``calibration.refine_intrinsics``), chosen from measurements (README, Calibration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from cell.calib.eyetohand import consistency_fixed, reprojection_fixed
from cell.calib.handeye import HandEyeData, consistency, reprojection
from cell.calib.transforms import make_transform, transform_from_rvec
from cell.errors import CalibrationError

__all__ = ["FREE_DISTORTION", "EyeToHandRefinement", "Refinement", "refine_eye_to_hand", "refine_hand_eye"]

FREE_DISTORTION = {0: (), 2: (0, 1), 4: (0, 1, 2, 3), 5: (0, 1, 2, 3, 4)}  # terms -> free indices
_LSQ = {"method": "trf", "x_scale": "jac", "ftol": 1e-12, "xtol": 1e-12, "gtol": 1e-12, "max_nfev": 400}


@dataclass(frozen=True, eq=False)
class Refinement:
    """The refined ``T_flange_camera`` and ``T_base_board`` (4x4, m); ``rms_px`` the
    reprojection RMS at the optimum and ``start_rms_px`` at the start (px); ``evaluations``
    of the residual; ``converged`` as scipy reports it."""

    T_flange_camera: np.ndarray
    T_base_board: np.ndarray
    rms_px: float
    start_rms_px: float
    evaluations: int
    converged: bool


def _unpack(x: np.ndarray, X0: np.ndarray, B0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    X = X0 @ transform_from_rvec(x[0:3], x[3:6])
    B = transform_from_rvec(x[6:9], np.zeros(3)) @ B0
    B = make_transform(B[:3, :3], B0[:3, 3] + x[9:12])
    return X, B


def _residuals(x: np.ndarray, data: HandEyeData, X0: np.ndarray, B0: np.ndarray) -> np.ndarray:
    X, B = _unpack(x, X0, B0)
    return (reprojection(data, X, B) - data.corners).reshape(-1)


def refine_hand_eye(data: HandEyeData, T_flange_camera: np.ndarray, *,
                    T_base_board: np.ndarray | None = None) -> Refinement:
    """Refine ``T_flange_camera`` (and the board pose, by default the average that it
    implies) to the least reprojection error over all views.

    Raises ``CalibrationError`` when the optimum is not finite.
    """
    X0 = np.asarray(T_flange_camera, dtype=np.float64)
    if T_base_board is None:
        B0, _ = consistency(data, X0)
    else:
        B0 = np.asarray(T_base_board, np.float64)
    r0 = _residuals(np.zeros(12), data, X0, B0)
    sol = least_squares(_residuals, np.zeros(12), args=(data, X0, B0), **_LSQ)
    X, B = _unpack(sol.x, X0, B0)
    if not (np.isfinite(X).all() and np.isfinite(B).all()):
        raise CalibrationError("hand-eye refinement: the optimum is not finite")
    m = len(r0) // 2
    return Refinement(
        T_flange_camera=X, T_base_board=B,
        rms_px=float(np.sqrt(np.sum(sol.fun**2) / m)), start_rms_px=float(np.sqrt(np.sum(r0**2) / m)),
        evaluations=int(sol.nfev), converged=bool(sol.success),
    )


@dataclass(frozen=True, eq=False)
class EyeToHandRefinement:
    """The refined ``T_base_camera`` and ``T_flange_board`` (4x4, m), the intrinsics ``K``
    (3x3, px) and ``dist`` (5,) used (refined when ``free_intrinsics``, else the ones given);
    ``rms_px`` the reprojection RMS at the optimum and ``start_rms_px`` at the start (px);
    ``evaluations`` of the residual; ``converged`` as scipy reports it."""

    T_base_camera: np.ndarray
    T_flange_board: np.ndarray
    K: np.ndarray
    dist: np.ndarray
    free_intrinsics: bool
    rms_px: float
    start_rms_px: float
    evaluations: int
    converged: bool


def _unpack_fixed(x: np.ndarray, start: tuple, free: tuple[int, ...]) -> tuple:
    C0, G0, K0, d0 = start
    C = C0 @ transform_from_rvec(x[0:3], x[3:6])
    G = transform_from_rvec(x[6:9], x[9:12]) @ G0
    K, d = K0.copy(), d0.copy()
    if len(x) > 12:
        K[0, 0] += x[12]
        K[1, 1] += x[13]
        K[0, 2] += x[14]
        K[1, 2] += x[15]
        d[list(free)] += x[16:]
    return C, G, K, d


def _residuals_fixed(x: np.ndarray, data: HandEyeData, start: tuple, free: tuple[int, ...]) -> np.ndarray:
    C, G, K, d = _unpack_fixed(x, start, free)
    return (reprojection_fixed(data, C, G, K=K, dist=d) - data.corners).reshape(-1)


def refine_eye_to_hand(data: HandEyeData, T_base_camera: np.ndarray, *,
                       T_flange_board: np.ndarray | None = None, free_intrinsics: bool = False,
                       terms: int = 4) -> EyeToHandRefinement:
    """Refine a fixed camera's ``T_base_camera`` and the board mount ``T_flange_board``
    (by default the average that ``T_base_camera`` implies) to the least reprojection error
    over all views (px); with ``free_intrinsics`` also fx, fy, cx, cy and the first
    ``terms`` (0, 2, 4 or 5) distortion coefficients, from the data's ``K`` and ``dist``.

    Raises ``CalibrationError`` for an unknown ``terms`` or an optimum that is not finite.
    """
    if terms not in FREE_DISTORTION:
        raise CalibrationError(f"eye-to-hand refinement: terms must be one of {sorted(FREE_DISTORTION)}, "
                               f"got {terms}")
    C0 = np.asarray(T_base_camera, dtype=np.float64)
    if T_flange_board is None:
        G0, _ = consistency_fixed(data, C0)
    else:
        G0 = np.asarray(T_flange_board, np.float64)
    start = (C0, G0, np.asarray(data.K, np.float64), np.asarray(data.dist, np.float64).copy())
    free = FREE_DISTORTION[terms] if free_intrinsics else ()
    n = 12 + (4 + len(free) if free_intrinsics else 0)
    r0 = _residuals_fixed(np.zeros(n), data, start, free)
    sol = least_squares(_residuals_fixed, np.zeros(n), args=(data, start, free), **_LSQ)
    C, G, K, d = _unpack_fixed(sol.x, start, free)
    if not all(np.isfinite(a).all() for a in (C, G, K, d)):
        raise CalibrationError("eye-to-hand refinement: the optimum is not finite")
    m = len(r0) // 2
    return EyeToHandRefinement(
        T_base_camera=C, T_flange_board=G, K=K, dist=d, free_intrinsics=bool(free_intrinsics),
        rms_px=float(np.sqrt(np.sum(sol.fun**2) / m)), start_rms_px=float(np.sqrt(np.sum(r0**2) / m)),
        evaluations=int(sol.nfev), converged=bool(sol.success),
    )
