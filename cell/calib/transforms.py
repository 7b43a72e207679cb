"""Rigid transforms for calibration: 4x4 homogeneous matrices, axis-angle, pose averages.

A transform ``T_a_b`` (4x4) maps coordinates in frame ``b`` to frame ``a``; translations
in metres, angles in radians unless a name says ``_deg``. Axis-angle vectors (``rvec``)
follow OpenCV's ``cv2.Rodrigues``.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = [
    "invert",
    "make_transform",
    "mean_transform",
    "pose_error",
    "project_to_rotation",
    "rotation_angle",
    "transform_from_rvec",
]


def make_transform(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The 4x4 transform with rotation ``R`` (3x3) and translation ``t`` (3,) metres."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(t, dtype=np.float64).reshape(3)
    return T


def invert(T: np.ndarray) -> np.ndarray:
    """The inverse of a rigid transform (4x4), or of a stack of them (..., 4, 4)."""
    R = T[..., :3, :3]
    t = T[..., :3, 3]
    out = np.zeros_like(T)
    Rt = np.swapaxes(R, -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, t)
    out[..., 3, 3] = 1.0
    return out


def transform_from_rvec(rvec: np.ndarray, tvec: np.ndarray) -> np.ndarray:
    """The 4x4 transform of an OpenCV axis-angle ``rvec`` (3,) rad and ``tvec`` (3,) m."""
    R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3, 1))
    return make_transform(R, tvec)


def rotation_angle(R: np.ndarray) -> float:
    """The angle (rad, 0..pi) of rotation ``R``: ``arccos((trace R - 1) / 2)``, computed
    through ``atan2`` of the skew part so that small angles keep their precision."""
    skew = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(np.arctan2(0.5 * np.linalg.norm(skew), 0.5 * (np.trace(R) - 1.0)))


def pose_error(T_est: np.ndarray, T_true: np.ndarray) -> tuple[float, float]:
    """(rotation error in degrees, translation error in metres) between two transforms:
    the angle of ``R_true^T R_est`` and ``|t_est - t_true|``."""
    dR = T_true[:3, :3].T @ T_est[:3, :3]
    return float(np.degrees(rotation_angle(dR))), float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3]))


def project_to_rotation(M: np.ndarray) -> np.ndarray:
    """The rotation nearest to ``M`` (3x3) in the Frobenius norm (SVD, det +1).

    Reference: Hartley, Trumpf, Dai, Li, *Rotation Averaging*, IJCV 103, 2013 (the
    chordal L2 mean is the projection of the arithmetic mean of the matrices).
    """
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def mean_transform(Ts: np.ndarray) -> np.ndarray:
    """The average of rigid transforms (N, 4, 4): chordal L2 mean of the rotations,
    arithmetic mean of the translations (metres)."""
    Ts = np.asarray(Ts, dtype=np.float64)
    return make_transform(project_to_rotation(Ts[:, :3, :3].sum(axis=0)), Ts[:, :3, 3].mean(axis=0))
