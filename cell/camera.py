"""``CameraModel``: a pinhole camera with distortion and a pose, as plain numpy data.

The same model describes the simulator's true camera, a calibrated one and a user's own
(``camera.json``). Axes follow OpenCV: x right, y down, z forward (out of the lens).
Units: pixels for ``K``, metres for the translation of ``T_world_camera``.

Every model is checked when it is made, whether in code, by :meth:`CameraModel.from_dict`
or by :meth:`CameraModel.load`: all values finite; ``width`` and ``height`` integers in
1..``MAX_SIDE``; ``K`` upper triangular with bottom row [0, 0, 1], fx and fy from
``FOCAL_RANGE[0]`` to ``FOCAL_RANGE[1]`` times the image's larger side (a field of view
across it of 179.8 down to 0.06 degrees), the principal point (cx, cy) within one image
size of the image (-width to 2 width, -height to 2 height) and no skew (OpenCV's model
has none); ``dist`` five numbers, each within +-``MAX_DISTORTION``; ``T_world_camera`` a rigid
transform: its rotation orthonormal with determinant +1 and its bottom row [0, 0, 0, 1],
each within ``TOLERANCE``, its translation within +-``MAX_TRANSLATION`` metres on each
axis. A failure is a ``CalibrationError`` naming the field (and the file, when loading);
a value out of its range is named with the range.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell import files
from cell.errors import CalibrationError
from cell.text import show

__all__ = ["FOCAL_RANGE", "MAX_DISTORTION", "MAX_FILE_BYTES", "MAX_SIDE", "MAX_TRANSLATION", "TOLERANCE",
           "CameraFields", "CameraModel", "check_camera_fields", "check_pose", "read_json_file"]

TOLERANCE = 1e-6  # absolute: |R^T R - I|, |det R - 1| and the fixed rows of K and T
MAX_SIDE = 1 << 16  # pixels: the largest width or height of a camera model
MAX_FILE_BYTES = 1 << 20  # a camera.json larger than this is no camera file
FOCAL_RANGE = (1e-3, 1e3)  # fx, fy over the image's larger side (a 4096x16 image at fovy 120: 1.1e-3)
MAX_DISTORTION = 100.0  # |k1|, |k2|, |p1|, |p2|, |k3| (lenses calibrate to a few units at most)
MAX_TRANSLATION = 100.0  # metres: |x|, |y|, |z| of a pose's translation (a cell is a few metres)
_REQUIRED = ("width", "height", "K", "T_world_camera")  # "dist" is optional (zeros)
_K_ROLES = {(0, 0): "fx", (1, 1): "fy", (0, 2): "cx", (1, 2): "cy", (0, 1): "skew"}


@dataclass(frozen=True, eq=False)
class CameraModel:
    """Intrinsics ``K`` (3x3), distortion ``dist`` (k1, k2, p1, p2, k3) and pose.

    ``T_world_camera`` (4x4) maps points from camera coordinates to world coordinates.
    ``width`` and ``height`` are the image size in pixels. Invalid values raise a
    ``CalibrationError`` naming the field (see the module docstring for the rules).
    """

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    T_world_camera: np.ndarray

    def __post_init__(self) -> None:
        try:
            f = check_camera_fields(self.width, self.height, self.K, self.dist, self.T_world_camera)
        except CalibrationError as exc:
            raise CalibrationError(f"CameraModel: {exc}") from None
        for name, value in (("width", f.width), ("height", f.height), ("K", f.K), ("dist", f.dist),
                            ("T_world_camera", f.pose)):
            object.__setattr__(self, name, value)

    @property
    def T_camera_world(self) -> np.ndarray:
        """The inverse pose: world coordinates to camera coordinates (4x4)."""
        R, t = self.T_world_camera[:3, :3], self.T_world_camera[:3, 3]
        out = np.eye(4)
        out[:3, :3] = R.T
        out[:3, 3] = -R.T @ t
        return out

    def project(self, points_world: np.ndarray, *, distort: bool = True) -> np.ndarray:
        """Pixel coordinates (N, 2) of world points (N, 3), metres in, pixels out.

        Uses the pinhole model and, when ``distort``, the Brown-Conrady distortion of
        ``cv2.projectPoints`` (written out here so it needs no OpenCV).
        """
        P = np.atleast_2d(np.asarray(points_world, dtype=np.float64))
        T = self.T_camera_world
        Pc = P @ T[:3, :3].T + T[:3, 3]
        return self.pixels_of(Pc[:, :2] / Pc[:, 2:3], distort=distort)

    def pixels_of(self, normalised: np.ndarray, *, distort: bool = True) -> np.ndarray:
        """Pixel coordinates (N, 2) of normalised image points (N, 2: x/z, y/z in the camera
        frame), through the lens distortion when ``distort``: the inverse of
        ``cv2.undistortPoints``, where that has an answer."""
        x, y = normalised[:, 0], normalised[:, 1]
        if distort and np.any(self.dist):
            k1, k2, p1, p2, k3 = self.dist
            r2 = x * x + y * y
            radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
            x, y = (
                x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y,
            )
        K = self.K
        return np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=1)

    def to_dict(self) -> dict:
        """The ``camera.json`` layout: width, height, K, dist, T_world_camera."""
        return {
            "width": int(self.width),
            "height": int(self.height),
            "K": self.K.tolist(),
            "dist": self.dist.tolist(),
            "T_world_camera": self.T_world_camera.tolist(),
        }

    def save(self, path: str | Path) -> None:
        """Write the model as ``camera.json``, whole or not at all (``CalibrationError``
        naming the path when it cannot be written)."""
        files.atomic_write_text(path, json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n",
                                kind="camera file", error=CalibrationError)

    @classmethod
    def from_dict(cls, data: object, *, where: str = "camera model") -> CameraModel:
        """A model from the ``camera.json`` layout (``dist`` optional, zeros by default).

        Any invalid content is a ``CalibrationError`` that starts with ``where`` and names
        the field. Extra keys are ignored.
        """
        try:
            f = check_camera_fields(*_fields(data))
        except CalibrationError as exc:
            raise CalibrationError(f"{where}: {exc}") from None
        return cls(f.width, f.height, f.K, f.dist, f.pose)

    @classmethod
    def load(cls, path: str | Path) -> CameraModel:
        """Read a ``camera.json``: a ``CalibrationError`` naming the file (escaped) and
        the field for an unreadable file or any invalid content."""
        path = Path(path)
        return cls.from_dict(read_json_file(path), where=f"camera file {str(path)!r}")

    @classmethod
    def from_calibration(cls, path: str | Path, name: str, *,
                         T_base_flange: np.ndarray | None = None) -> CameraModel:
        """The model of camera ``name`` in a calibration file (``cell calibrate --out``).

        The file is read and checked by :func:`cell.calib.load_calibration` (every field,
        as here). The cell's world frame is the robot's base frame. A fixed camera's
        ``T_world_camera`` is its ``T_base_camera``; a wrist camera's pose moves with the
        arm, so it needs the flange pose at the time of the image, ``T_base_flange``
        (4x4, m), and is ``T_base_flange @ T_flange_camera``. A ``CalibrationError`` names
        the file and what is missing or wrong.
        """
        from cell.calib.calfile import load_calibration  # (calib depends on this module)

        entry = load_calibration(path).camera(name)
        return entry.camera_model(T_base_flange=T_base_flange)


def read_json_file(path: str | Path, *, kind: str = "camera file") -> object:
    """The JSON value in the file ``path``: a ``CalibrationError`` starting with ``kind``
    and the file's name for a missing, unreadable, oversized, non-UTF-8 or non-JSON file
    (:func:`cell.files.read_json_file`)."""
    path = Path(path)
    return files.read_json_file(path, f"{kind} {str(path)!r}", kind=kind, limit=MAX_FILE_BYTES,
                                error=CalibrationError)


def _fields(data: object) -> tuple:
    """width, height, K, dist, T_world_camera out of a ``camera.json`` value."""
    if not isinstance(data, dict):
        raise CalibrationError(f"expected a JSON object with keys {', '.join(_REQUIRED)} (and dist), "
                               f"got {_json_type(data)}")
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise CalibrationError(f"missing key '{missing[0]}' (need {', '.join(_REQUIRED)}; dist optional)")
    return data["width"], data["height"], data["K"], data.get("dist", [0.0] * 5), data["T_world_camera"]


@dataclass(frozen=True, eq=False)
class CameraFields:
    """A camera's five fields, checked: image ``width`` and ``height`` (px), ``K`` (3x3),
    ``dist`` (5,) and a ``pose`` (4x4, m; ``T_world_camera`` or a calibration file's
    ``T_flange_camera``/``T_base_camera``), float64 arrays."""

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    pose: np.ndarray


def check_camera_fields(width: object, height: object, K: object, dist: object, pose: object, *,
                        pose_name: str = "T_world_camera") -> CameraFields:
    """The five fields of a camera (image size, ``K``, ``dist`` and a pose named
    ``pose_name``), checked as the module docstring says and converted; a
    ``CalibrationError`` naming the field otherwise. Calibration files reuse it for
    ``T_flange_camera`` and ``T_base_camera``."""
    width, height = _side("width", width), _side("height", height)
    K = _array("K", K, (3, 3))
    dist = _array("dist", dist, (5,))
    T = check_pose(pose_name, pose)
    _check_intrinsics(K, width, height)
    _check_distortion(dist)
    return CameraFields(width, height, K, dist, T)


def check_pose(name: str, value: object) -> np.ndarray:
    """A rigid transform (4x4, metres) as a float64 array: finite, bottom row [0, 0, 0, 1],
    a rotation (orthonormal, det +1), a translation within ``MAX_TRANSLATION``; a
    ``CalibrationError`` naming ``name`` otherwise."""
    T = _array(name, value, (4, 4))
    _check_pose(T, name)
    return T


def _side(name: str, value: object) -> int:
    if not _is_int(value) or not 1 <= value <= MAX_SIDE:
        raise CalibrationError(f"'{name}' must be an integer in 1..{MAX_SIDE} (pixels), got {show(value)}")
    return int(value)


def _array(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as a finite float64 array of ``shape`` (``dist`` may be any 5-element array)."""
    want = "x".join(map(str, shape)) if len(shape) > 1 else f"{shape[0]} numbers"
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "iuf":
            raise CalibrationError(f"'{name}' must hold real numbers, got dtype {value.dtype}")
        arr = value.astype(np.float64)
    else:
        arr = _from_lists(name, value, want)
    if len(shape) == 1 and arr.size == shape[0] and arr.ndim <= 2:
        arr = arr.reshape(-1)  # OpenCV gives dist as (1, 5)
    if arr.shape != shape:
        raise CalibrationError(f"'{name}' must be {want}, got shape {arr.shape}")
    bad = np.argwhere(~np.isfinite(arr))
    if len(bad):
        at = tuple(int(i) for i in bad[0])
        raise CalibrationError(f"{_element(name, at)} must be finite, got {arr[at]}")
    return arr


def _from_lists(name: str, value: object, want: str) -> np.ndarray:
    """A float64 array from a list (of lists) of real numbers: no bools, strings or nulls."""
    if not isinstance(value, list | tuple):
        raise CalibrationError(f"'{name}' must be {want} (a list), got {_json_type(value)}")
    rows = value if all(isinstance(r, list | tuple) for r in value) and value else None
    items = ([((i, j), x) for i, r in enumerate(rows) for j, x in enumerate(r)] if rows is not None
             else [((i,), x) for i, x in enumerate(value)])
    for at, x in items:
        if not _is_real(x):
            raise CalibrationError(f"{_element(name, at)} must be a number, got {show(x)}")
        try:
            float(x)
        except OverflowError:  # an integer of 400 digits
            raise CalibrationError(f"{_element(name, at)} must be finite, got {show(x)}") from None
    if rows is not None and len({len(r) for r in rows}) > 1:
        raise CalibrationError(f"'{name}' must be {want}, got rows of lengths {[len(r) for r in rows]}")
    return np.array(value, dtype=np.float64)


def _check_intrinsics(K: np.ndarray, width: int, height: int) -> None:
    for at in ((0, 0), (1, 1)):
        if not K[at] > 0:
            raise CalibrationError(f"{_element('K', at)} must be > 0 (pixels), got {K[at]}")
    if not np.abs(K[2] - [0.0, 0.0, 1.0]).max() <= TOLERANCE:
        raise CalibrationError(f"'K[2]' (bottom row) must be [0, 0, 1], got {_row(K[2])}")
    if not abs(K[1, 0]) <= TOLERANCE:
        raise CalibrationError(f"'K[1][0]' must be 0 (K is upper triangular), got {K[1, 0]}")
    lo, hi = FOCAL_RANGE
    side = max(width, height)
    for at in ((0, 0), (1, 1)):
        _within("K", K, at, lo * side, hi * side,
                f"pixels: {lo:g} to {hi:g} times the larger of 'width' {width} and 'height' {height}")
    _within("K", K, (0, 2), -width, 2 * width, f"pixels: -1 to 2 times 'width' {width}")
    _within("K", K, (1, 2), -height, 2 * height, f"pixels: -1 to 2 times 'height' {height}")
    if not abs(K[0, 1]) <= TOLERANCE:  # cv2.undistortPoints, cv2.projectPoints and
        # calibrateCamera know no skew: a model with one would be read two ways
        raise CalibrationError(f"{_element('K', (0, 1))} must be 0 (OpenCV's camera model, which "
                               f"the detector and the calibration use, has no skew), got {K[0, 1]}")


def _check_distortion(dist: np.ndarray) -> None:
    for i in range(5):
        _within("dist", dist, (i,), -MAX_DISTORTION, MAX_DISTORTION, "k1, k2, p1, p2, k3 each")


def _within(name: str, arr: np.ndarray, at: tuple[int, ...], lo: float, hi: float,
            unit: str = "") -> None:
    """A ``CalibrationError`` naming element ``at`` of field ``name``, its value and the
    range, unless the value lies in [lo, hi]."""
    if not lo <= arr[at] <= hi:
        what = f" ({unit})" if unit else ""
        raise CalibrationError(f"{_element(name, at)} must be {lo:g} to {hi:g}{what}, got {arr[at]}")


def _check_pose(T: np.ndarray, name: str = "T_world_camera") -> None:
    if not np.abs(T[3] - [0.0, 0.0, 0.0, 1.0]).max() <= TOLERANCE:
        raise CalibrationError(f"'{name}[3]' (bottom row) must be [0, 0, 0, 1], got {_row(T[3])}")
    R = T[:3, :3]
    with np.errstate(over="ignore", invalid="ignore"):  # R of 1e308: off is inf or nan, refused
        off = float(np.abs(R.T @ R - np.eye(3)).max())
    if not off <= TOLERANCE:
        raise CalibrationError(f"'{name}' rotation (top-left 3x3) is not orthonormal: "
                               f"max |R^T R - I| = {off:.3g}, tolerance {TOLERANCE:g}")
    if not np.linalg.det(R) > 0:  # orthonormal, so det is -1: a mirror image, not a rotation
        raise CalibrationError(f"'{name}' rotation (top-left 3x3) is a reflection: "
                               "det = -1, must be +1")
    for i in range(3):
        _within(name, T, (i, 3), -MAX_TRANSLATION, MAX_TRANSLATION, "metres, the translation")


def _is_int(x: object) -> bool:
    return isinstance(x, int | np.integer) and not isinstance(x, bool)


def _is_real(x: object) -> bool:
    return isinstance(x, int | float | np.integer | np.floating) and not isinstance(x, bool)


def _element(name: str, at: tuple[int, ...]) -> str:
    index = "".join(f"[{i}]" for i in at)
    role = _K_ROLES.get(at) if name == "K" else None
    return f"'{name}{index}'" + (f" ({role})" if role else "")


def _row(values: np.ndarray) -> str:
    return "[" + ", ".join(f"{v:g}" for v in values) + "]"


def _json_type(value: object) -> str:
    names = {type(None): "null", bool: "a boolean", int: "a number", float: "a number",
             str: "a string", list: "a list", tuple: "a list", dict: "an object"}
    return names.get(type(value), type(value).__name__) + (f" {show(value)}" if _is_real(value) else "")
