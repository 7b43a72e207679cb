"""``CameraModel``: a pinhole camera with distortion and a pose, as plain numpy data.

The same model describes the simulator's true camera, a calibrated one and a user's own
(``camera.json``). Axes follow OpenCV: x right, y down, z forward (out of the lens).
Units: pixels for ``K``, metres for the translation of ``T_world_camera``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell.errors import CellError

__all__ = ["CameraModel"]


@dataclass(frozen=True, eq=False)
class CameraModel:
    """Intrinsics ``K`` (3x3), distortion ``dist`` (k1, k2, p1, p2, k3) and pose.

    ``T_world_camera`` (4x4) maps points from camera coordinates to world coordinates.
    ``width`` and ``height`` are the image size in pixels.
    """

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    T_world_camera: np.ndarray

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=np.float64)
        dist = np.asarray(self.dist, dtype=np.float64).reshape(-1)
        T = np.asarray(self.T_world_camera, dtype=np.float64)
        if K.shape != (3, 3):
            raise CellError(f"CameraModel: K must be 3x3, got shape {K.shape}")
        if dist.shape != (5,):
            raise CellError(f"CameraModel: dist must have 5 elements, got {dist.shape[0]}")
        if T.shape != (4, 4):
            raise CellError(f"CameraModel: T_world_camera must be 4x4, got shape {T.shape}")
        if self.width <= 0 or self.height <= 0:
            raise CellError(f"CameraModel: size must be positive, got {self.width}x{self.height}")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", dist)
        object.__setattr__(self, "T_world_camera", T)

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
        x, y = Pc[:, 0] / Pc[:, 2], Pc[:, 1] / Pc[:, 2]
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
        """Write the model as ``camera.json``."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=2) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> CameraModel:
        """Read a ``camera.json``; a missing key or bad shape is a ``CellError`` naming it."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise CellError(f"{path}: no such camera file") from None
        except json.JSONDecodeError as exc:
            raise CellError(f"{path}: not valid JSON: {exc}") from None
        missing = [k for k in ("width", "height", "K", "T_world_camera") if k not in data]
        if missing:
            raise CellError(f"{path}: missing key '{missing[0]}' (need width, height, K, T_world_camera)")
        try:
            return cls(
                width=int(data["width"]),
                height=int(data["height"]),
                K=np.array(data["K"], dtype=np.float64),
                dist=np.array(data.get("dist", [0.0] * 5), dtype=np.float64),
                T_world_camera=np.array(data["T_world_camera"], dtype=np.float64),
            )
        except (TypeError, ValueError) as exc:
            raise CellError(f"{path}: {exc}") from None
