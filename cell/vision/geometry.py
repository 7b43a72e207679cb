"""Plane geometry: homographies, the bird's-eye view of the table, inverse perspective
(pixel -> point on the table plane) and the pose of a planar target (PnP).

Frames: ``T_world_camera`` (4x4) maps camera coordinates (OpenCV axes: x right, y down,
z forward) to world coordinates (metres, z up, table plane ``z = const``). Pixels are
(x, y) = (column, row) in numpy index convention.

References: R. Hartley and A. Zisserman, *Multiple View Geometry*, 2nd ed., ch. 2 and
4 (homographies, DLT) and 8.1 (back-projection of a pixel to a ray); Z. Zhang, "A
flexible new technique for camera calibration", PAMI 22(11), 2000 (plane-to-image
homography ``K [r1 r2 t]``); T. Collins and A. Bartoli, "Infinitesimal plane-based
pose estimation", IJCV 109, 2014 (IPPE); OpenCV ``getPerspectiveTransform``,
``undistortPoints``, ``solvePnP``, ``remap``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.camera import CameraModel
from cell.errors import VisionError
from cell.vision._checks import check_image, check_points

__all__ = [
    "PlanarPose",
    "apply_homography",
    "birdseye_view",
    "homography_from_points",
    "pixel_to_table",
    "solve_planar_pnp",
    "table_homography",
]


def _check_camera(camera: object) -> CameraModel:
    if not isinstance(camera, CameraModel):
        raise VisionError(f"argument 'camera': expected a CameraModel, got {type(camera).__name__}")
    return camera


def homography_from_points(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """The 3x3 homography ``H`` (``H[2, 2] = 1``) with ``dst ~ H src`` for four point pairs.

    src, dst : (4, 2) points (any units), no three collinear. Solves the 8x8 linear
    system of the DLT (Hartley & Zisserman 4.1). Wraps ``cv2.getPerspectiveTransform``.
    """
    s = check_points("src", src, count=4)
    d = check_points("dst", dst, count=4)
    for name, p in (("src", s), ("dst", d)):
        for i in range(4):
            a, b, c = np.delete(p, i, axis=0)
            cross = (b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0]
            scale = max(np.ptp(p, axis=0).max(), 1e-12)
            if abs(cross) < 1e-9 * scale**2:
                raise VisionError(f"argument '{name}': three of the four points are collinear")
    return cv2.getPerspectiveTransform(s.astype(np.float32), d.astype(np.float32)).astype(
        np.float64
    )


def apply_homography(H: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Map (N, 2) points through the 3x3 homography ``H`` (with the division by w)."""
    H = np.asarray(H, dtype=np.float64)
    if H.shape != (3, 3):
        raise VisionError(f"argument 'H': expected shape (3, 3), got {H.shape}")
    p = check_points("points", points)
    q = np.c_[p, np.ones(len(p))] @ H.T
    return q[:, :2] / q[:, 2:3]


def table_homography(camera: CameraModel, *, z: float = 0.0) -> np.ndarray:
    """``H`` mapping table-plane points (X, Y, 1) (metres, on the plane ``z``) to
    undistorted pixels: ``H = K [r1  r2  r3 z + t]`` with ``[R | t] = T_camera_world``
    (Zhang 2000). Lens distortion is not in it: undistort pixels first."""
    cam = _check_camera(camera)
    T = cam.T_camera_world
    R, t = T[:3, :3], T[:3, 3]
    H = cam.K @ np.c_[R[:, 0], R[:, 1], R[:, 2] * z + t]
    return H / H[2, 2]


def pixel_to_table(camera: CameraModel, pixels: np.ndarray, *, z: float = 0.0) -> np.ndarray:
    """Inverse perspective: the world points (N, 3) where the pixels' rays meet the
    plane ``z`` (metres).

    Each pixel is undistorted (``cv2.undistortPointsIter`` with the model's
    ``dist``, iterated to 1e-14), turned into a ray from the camera centre, rotated into the world
    frame and intersected with the plane. A ray parallel to the plane or meeting it
    behind the camera is an error naming the pixel.

    Parameters
    ----------
    camera : the ``CameraModel`` (K, dist, T_world_camera).
    pixels : (N, 2) pixel coordinates (x, y).
    z : height of the plane in the world frame (metres), e.g. the belt top.
    """
    cam = _check_camera(camera)
    px = check_points("pixels", pixels)
    norm = cv2.undistortPointsIter(
        px.reshape(-1, 1, 2), cam.K, cam.dist, np.eye(3), np.eye(3),
        (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14),
    ).reshape(-1, 2)
    rays_cam = np.c_[norm, np.ones(len(norm))]
    R, c = cam.T_world_camera[:3, :3], cam.T_world_camera[:3, 3]
    rays = rays_cam @ R.T
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (z - c[2]) / rays[:, 2]
    bad = ~np.isfinite(s) | (s <= 0)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise VisionError(
            f"argument 'pixels': pixel {px[i].tolist()} does not see the plane z = {z} "
            "in front of the camera"
        )
    return c + s[:, None] * rays


def birdseye_view(
    image: np.ndarray,
    camera: CameraModel,
    *,
    x_range: tuple[float, float],
    y_range: tuple[float, float],
    resolution: float,
    z: float = 0.0,
) -> np.ndarray:
    """Resample ``image`` onto a metric top-down grid of the plane ``z``.

    Output pixel (row i, column j) shows the world point ``x = x0 + (j + 0.5) res``,
    ``y = y1 - (i + 0.5) res`` (so +x points right and +y up, like a map). Every
    output pixel is projected into the image through the full camera model
    (distortion included) and sampled bilinearly (``cv2.remap``); points outside the
    image are black.

    Parameters
    ----------
    image : uint8 (H, W) or (H, W, 3), the camera's image.
    camera : its ``CameraModel``.
    x_range, y_range : (min, max) world extent in metres.
    resolution : metres per output pixel.
    """
    image = check_image("image", image)
    cam = _check_camera(camera)
    if resolution <= 0:
        raise VisionError(f"argument 'resolution': expected > 0 metres per pixel, got {resolution}")
    (x0, x1), (y0, y1) = x_range, y_range
    if x1 <= x0 or y1 <= y0:
        raise VisionError("arguments 'x_range', 'y_range': each must be (min, max) with min < max")
    w = round((x1 - x0) / resolution)
    h = round((y1 - y0) / resolution)
    xs = x0 + (np.arange(w) + 0.5) * resolution
    ys = y1 - (np.arange(h) + 0.5) * resolution
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([X.ravel(), Y.ravel(), np.full(X.size, z)], axis=1)
    uv = cam.project(pts).reshape(h, w, 2).astype(np.float32)
    return cv2.remap(image, uv[..., 0], uv[..., 1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)


@dataclass(frozen=True, eq=False)
class PlanarPose:
    """Pose of a planar target: ``T_camera_target`` (4x4, metres) and the RMS
    reprojection error of its points (pixels)."""

    T_camera_target: np.ndarray
    rms_px: float


def solve_planar_pnp(
    object_points: np.ndarray,
    image_points: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray | None = None,
) -> PlanarPose:
    """Pose of a known planar target from its image (Perspective-n-Point).

    IPPE (exact for planar targets, no initial guess) followed by Levenberg-Marquardt
    refinement of the reprojection error.

    Parameters
    ----------
    object_points : (N, 2) or (N, 3) target points in the target frame (metres),
        on its z = 0 plane; N >= 4.
    image_points : (N, 2) their pixels.
    K : 3x3 intrinsics; dist : 5 distortion coefficients (or None).
    """
    obj = np.asarray(object_points, dtype=np.float64)
    if obj.ndim == 2 and obj.shape[1] == 2:
        obj = np.c_[obj, np.zeros(len(obj))]
    obj = check_points("object_points", obj, dim=3)
    if np.ptp(obj[:, 2]) > 1e-9 or len(obj) < 4:
        raise VisionError("argument 'object_points': need >= 4 points on the target's z = 0 plane")
    img = check_points("image_points", image_points, count=len(obj))
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3):
        raise VisionError(f"argument 'K': expected shape (3, 3), got {K.shape}")
    d = np.zeros(5) if dist is None else np.asarray(dist, dtype=np.float64).reshape(-1)
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, d, flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        raise VisionError("argument 'image_points': PnP found no pose for these points")
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, d, rvec, tvec)
    proj, _ = cv2.projectPoints(obj, rvec, tvec, K, d)
    rms = float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - img) ** 2, axis=1))))
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(rvec)[0]
    T[:3, 3] = tvec.ravel()
    return PlanarPose(T, rms)
