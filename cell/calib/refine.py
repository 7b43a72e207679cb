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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from cell.calib.handeye import HandEyeData, consistency, reprojection
from cell.calib.transforms import make_transform, transform_from_rvec
from cell.errors import CalibrationError

__all__ = ["Refinement", "refine_hand_eye"]


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
    B0 = consistency(data, X0)[0] if T_base_board is None else np.asarray(T_base_board, np.float64)
    r0 = _residuals(np.zeros(12), data, X0, B0)
    sol = least_squares(_residuals, np.zeros(12), args=(data, X0, B0), method="trf",
                        x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12, max_nfev=400)
    X, B = _unpack(sol.x, X0, B0)
    if not (np.isfinite(X).all() and np.isfinite(B).all()):
        raise CalibrationError("hand-eye refinement: the optimum is not finite")
    m = len(r0) // 2
    return Refinement(
        T_flange_camera=X, T_base_board=B,
        rms_px=float(np.sqrt(np.sum(sol.fun**2) / m)), start_rms_px=float(np.sqrt(np.sum(r0**2) / m)),
        evaluations=int(sol.nfev), converged=bool(sol.success),
    )
