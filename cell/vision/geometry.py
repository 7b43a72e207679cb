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

import math
from dataclasses import dataclass

import cv2
import numpy as np

from cell.camera import CameraModel
from cell.errors import VisionError
from cell.vision._checks import check_image, check_points, check_range

__all__ = [
    "PlanarPose",
    "apply_homography",
    "birdseye_view",
    "homography_from_points",
    "no_ray",
    "pixel_to_table",
    "solve_planar_pnp",
    "table_homography",
]


_FAR = 1e3  # m: the largest plane height and world extent taken
_MAX_VIEW = 2**22  # the most pixels a bird's-eye view may have (2048 x 2048)
_DIST_COUNTS = (4, 5, 8, 12, 14)  # OpenCV's distortion models
# px: an undistorted point that maps back further than this has no ray (a fold puts it
# pixels to tens of pixels off; cv2.undistortPointsIter may stop 0.1 px short near the
# corners of a wide lens that folds nothing)
_NO_RAY_PX = 0.5


def _check_camera(camera: object) -> CameraModel:
    if not isinstance(camera, CameraModel):
        raise VisionError(f"argument 'camera': expected a CameraModel, got {type(camera).__name__}")
    return camera


def _check_matrix(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as a float64 array of ``shape`` whose values are all finite."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise VisionError(f"argument '{name}': expected a {shape} array of numbers") from None
    if arr.shape != shape:
        raise VisionError(f"argument '{name}': expected shape {shape}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise VisionError(f"argument '{name}': holds NaN or infinite values; every value must be finite")
    return arr


def _check_z(camera: CameraModel, z: object) -> float:
    """A plane height (m) in [-1000, 1000], below the camera's centre."""
    z = check_range("z", z, -_FAR, _FAR)
    if z >= (top := float(camera.T_world_camera[2, 3])):
        raise VisionError(f"argument 'z': the plane z = {z} must lie below the camera "
                          f"(its centre at z = {top:.6g} m)")
    return z


def homography_from_points(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """The 3x3 homography ``H`` (``H[2, 2] = 1``) with ``dst ~ H src`` for four point pairs.

    src, dst : (4, 2) finite points (any units), no three collinear. Solves the 8x8
    linear system of the DLT (Hartley & Zisserman 4.1). Wraps
    ``cv2.getPerspectiveTransform``, which takes float32: each set is first scaled by a
    power of two (exact) to within [-1, 1], and ``H`` scaled back, so that points far
    beyond float32's range (1e39) or tiny (1e-30) work too. An ``H`` that overflows
    float64 (the two sets' scales some 1e300 apart) is an error.
    """
    s = check_points("src", src, count=4)
    d = check_points("dst", dst, count=4)
    scales = []
    for name, p in (("src", s), ("dst", d)):
        top = float(np.abs(p).max())
        scales.append(2.0 ** -math.frexp(top)[1] if top > 0 else 1.0)
        q = p * scales[-1]
        scale = np.ptp(q, axis=0).max()
        for i in range(4):
            a, b, c = np.delete(q, i, axis=0)
            cross = (b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0]
            if abs(cross) <= 1e-9 * scale**2:
                raise VisionError(f"argument '{name}': three of the four points are collinear")
    ks, kd = scales
    Hn = cv2.getPerspectiveTransform((s * ks).astype(np.float32), (d * kd).astype(np.float32))
    with np.errstate(over="ignore", invalid="ignore"):
        H = np.diag([1 / kd, 1 / kd, 1.0]) @ Hn.astype(np.float64) @ np.diag([ks, ks, 1.0])
    if not np.isfinite(H).all():
        raise VisionError("arguments 'src', 'dst': the homography between them overflows "
                          "float64 (their scales are too far apart)")
    return H


def apply_homography(H: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Map (N, 2) points through the 3x3 homography ``H`` (with the division by w).

    H : 3x3 finite, invertible (rank 3). points : (N, 2) finite; a point that ``H`` sends
    to infinity (w = 0: it lies on the line ``H`` maps to the line at infinity) is an
    error naming it."""
    H = _check_matrix("H", H, (3, 3))
    norms = np.linalg.norm(H, axis=1)
    # rank of H with each row scaled to length 1: a homography between point sets of
    # scales 1e-30 and 1 is diag(1e-30, 1e-30, 1), invertible, though its singular values
    # span 30 decades (the rank's relative tolerance called it singular)
    if not norms.all() or np.linalg.matrix_rank(H / norms[:, None]) < 3:
        raise VisionError("argument 'H': singular (rank below 3): not a homography")
    p = check_points("points", points)
    q = np.c_[p, np.ones(len(p))] @ H.T
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        out = q[:, :2] / q[:, 2:3]
    if not np.isfinite(out).all():
        i = int(np.argmax(~np.isfinite(out).all(axis=1)))
        raise VisionError(f"argument 'points': point {p[i].tolist()} maps to infinity "
                          "(w = 0: it lies on the line H sends to the line at infinity)")
    return out


def table_homography(camera: CameraModel, *, z: float = 0.0) -> np.ndarray:
    """``H`` mapping table-plane points (X, Y, 1) (metres, on the plane ``z``) to
    undistorted pixels: ``H = K [r1  r2  r3 z + t]`` with ``[R | t] = T_camera_world``
    (Zhang 2000), scaled to ``H[2, 2] = 1``. Lens distortion is not in it: undistort
    pixels first. ``z`` in [-1000, 1000] m and below the camera's centre; a plane whose
    point (0, 0, z) lies in the camera's focal plane (``H[2, 2] = 0``) is an error."""
    cam = _check_camera(camera)
    z = _check_z(cam, z)
    T = cam.T_camera_world
    R, t = T[:3, :3], T[:3, 3]
    H = cam.K @ np.c_[R[:, 0], R[:, 1], R[:, 2] * z + t]
    if not abs(H[2, 2]) > 1e-12 * np.abs(H).max():
        raise VisionError(f"argument 'camera': the point (0, 0, {z}) lies in its focal plane "
                          "(H[2, 2] = 0): H cannot be scaled to H[2, 2] = 1")
    return H / H[2, 2]


def no_ray(camera: CameraModel, normalised: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """Mask (N,) of the ``pixels`` (N, 2) whose undistorted points ``normalised`` (N, 2, from
    ``cv2.undistortPoints``) do not map back onto them through ``camera``'s lens model
    within 0.5 px: a model that folds the image has no ray for such a pixel (or two), and
    the undistortion's iteration stops anywhere."""
    with np.errstate(invalid="ignore", over="ignore"):
        back = camera.pixels_of(np.asarray(normalised, dtype=np.float64))
        return ~(np.abs(back - pixels).max(axis=1) <= _NO_RAY_PX)


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
    pixels : (N, 2) pixel coordinates (x, y); none (0, 2) gives none (0, 3).
    z : height of the plane in the world frame (metres), e.g. the belt top: in
        [-1000, 1000] and below the camera's centre.
    """
    cam = _check_camera(camera)
    px = check_points("pixels", pixels)
    z = _check_z(cam, z)
    if len(px) == 0:
        return np.zeros((0, 3))
    norm = cv2.undistortPointsIter(
        px.reshape(-1, 1, 2), cam.K, cam.dist, np.eye(3), np.eye(3),
        (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14),
    ).reshape(-1, 2)
    lost = no_ray(cam, norm, px)
    if np.any(lost):
        i = int(np.argmax(lost))
        raise VisionError(f"pixel_to_table: pixel ({px[i, 0]:g}, {px[i, 1]:g}) has no ray: the "
                          "camera's lens model ('dist') folds the image there")
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
    image are black, and so are points the camera cannot see: behind it, or past a fold
    of its lens model (where a strong distortion turns back: the pixel such a point
    projects to sees a nearer point, as :func:`no_ray` tells).

    Parameters
    ----------
    image : uint8 (H, W) or (H, W, 3), the camera's image.
    camera : its ``CameraModel``.
    image : uint8 (H, W) or (H, W, 3), the camera's image (its size the model's).
    camera : its ``CameraModel``.
    x_range, y_range : (min, max) world extent in metres, each in [-1000, 1000].
    resolution : metres per output pixel, in [1e-9, 1000]; the view must come out at
        least 1 pixel a side and at most 2**22 pixels (2048 x 2048) in all.
    z : height of the plane (m), in [-1000, 1000] and below the camera's centre.
    """
    image = check_image("image", image)
    cam = _check_camera(camera)
    if image.shape[:2] != (cam.height, cam.width):
        raise VisionError(f"argument 'image': {image.shape[1]} x {image.shape[0]} pixels, but the "
                          f"camera model's images are {cam.width} x {cam.height}")
    resolution = check_range("resolution", resolution, 1e-9, _FAR)
    (x0, x1), (y0, y1) = _check_span("x_range", x_range), _check_span("y_range", y_range)
    z = _check_z(cam, z)
    w = round((x1 - x0) / resolution)
    h = round((y1 - y0) / resolution)
    if not (w >= 1 and h >= 1 and w * h <= _MAX_VIEW):
        raise VisionError(f"argument 'resolution': {resolution} m per pixel gives a {w} x {h} "
                          f"pixel view; it must be at least 1 x 1 and at most {_MAX_VIEW} pixels "
                          "(2048 x 2048)")
    xs = x0 + (np.arange(w) + 0.5) * resolution
    ys = y1 - (np.arange(h) + 0.5) * resolution
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([X.ravel(), Y.ravel(), np.full(X.size, z)], axis=1)
    uv = _seen_at(cam, pts).reshape(h, w, 2).astype(np.float32)
    return cv2.remap(image, uv[..., 0], uv[..., 1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def _seen_at(cam: CameraModel, points: np.ndarray) -> np.ndarray:
    """The pixels (N, 2) where ``cam`` sees the world points (N, 3); far outside the
    image (-1e6) for a point it cannot see: behind the camera, or past a fold of its lens
    model (where the pixel it projects to sees a nearer point: undistorting that pixel
    does not give the point's ray back within 0.5 px)."""
    T = cam.T_camera_world
    P = points @ T[:3, :3].T + T[:3, 3]
    ahead = P[:, 2] > 0
    norm = np.zeros((len(P), 2))
    norm[ahead] = P[ahead, :2] / P[ahead, 2:3]
    uv = cam.pixels_of(norm)
    seen = ahead & np.isfinite(uv).all(axis=1)
    if np.any(cam.dist):  # only the pixels in the image can show a fold
        near = seen & (uv[:, 0] > -2) & (uv[:, 0] < cam.width + 1) & (uv[:, 1] > -2) & (
            uv[:, 1] < cam.height + 1)
        back = cv2.undistortPointsIter(
            uv[near].reshape(-1, 1, 2), cam.K, cam.dist, np.eye(3), np.eye(3),
            (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)).reshape(-1, 2)
        off = np.abs(back - norm[near]).max(axis=1) * max(cam.K[0, 0], cam.K[1, 1])
        seen[np.flatnonzero(near)[~(off <= _NO_RAY_PX)]] = False
    uv[~seen] = -1e6
    return uv


def _check_span(name: str, value: object) -> tuple[float, float]:
    """A (min, max) pair of numbers in [-1000, 1000] with min < max."""
    try:
        lo, hi = value  # type: ignore[misc]
    except (TypeError, ValueError):
        raise VisionError(f"argument '{name}': expected (min, max), got {value!r}") from None
    lo, hi = check_range(name, lo, -_FAR, _FAR), check_range(name, hi, -_FAR, _FAR)
    if not lo < hi:
        raise VisionError(f"argument '{name}': expected (min, max) with min < max, got {value!r}")
    return lo, hi


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
    object_points : (N, 2) or (N, 3) finite target points in the target frame (metres),
        on its z = 0 plane, not all on one line; N >= 4.
    image_points : (N, 2) their pixels, finite.
    K : 3x3 finite intrinsics, ``fx``, ``fy`` > 0 and last row (0, 0, 1);
    dist : 4, 5, 8, 12 or 14 finite distortion coefficients (OpenCV's order), or None.

    Image points from which no finite pose follows (all at one pixel, say) are an error.
    """
    try:
        dim = 3 if np.asarray(object_points, dtype=np.float64).shape[-1:] == (3,) else 2
    except (TypeError, ValueError):
        dim = 2  # (check_points says what is wrong)
    obj = check_points("object_points", object_points, dim=dim)
    if obj.shape[1] == 2:
        obj = np.c_[obj, np.zeros(len(obj))]
    if np.ptp(obj[:, 2]) > 1e-9 or len(obj) < 4:
        raise VisionError("argument 'object_points': need >= 4 points on the target's z = 0 plane")
    sv = np.linalg.svd(obj[:, :2] - obj[:, :2].mean(axis=0), compute_uv=False)
    if not sv[1] > 1e-9 * sv[0]:
        raise VisionError("argument 'object_points': the points lie on one line (or at one point)")
    img = check_points("image_points", image_points, count=len(obj))
    K = _check_matrix("K", K, (3, 3))
    if not (K[0, 0] > 0 and K[1, 1] > 0 and np.array_equal(K[2], [0.0, 0.0, 1.0])):
        raise VisionError("argument 'K': expected intrinsics with fx, fy > 0 and last row (0, 0, 1)")
    d = np.zeros(5) if dist is None else _check_matrix("dist", np.ravel(dist), (np.size(dist),))
    if d.size not in _DIST_COUNTS:
        raise VisionError(f"argument 'dist': expected 4, 5, 8, 12 or 14 coefficients, got {d.size}")
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, d, flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        raise VisionError("argument 'image_points': PnP found no pose for these points")
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, d, rvec, tvec)
    proj, _ = cv2.projectPoints(obj, rvec, tvec, K, d)
    rms = float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - img) ** 2, axis=1))))
    if not (np.isfinite(rvec).all() and np.isfinite(tvec).all() and math.isfinite(rms)):
        raise VisionError("argument 'image_points': PnP found no finite pose for these points")
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(rvec)[0]
    T[:3, 3] = tvec.ravel()
    return PlanarPose(T, rms)
