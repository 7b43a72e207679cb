"""Cameras: the fixed overhead camera, true camera models, and rendering to a ``Frame``.

MuJoCo cameras look along their frame's -z with +y up; OpenCV cameras look along +z with
+y down. ``true_camera_model`` converts one to the other: the OpenCV camera's rotation is
MuJoCo's times diag(1, -1, -1). Intrinsics follow from ``fovy`` (NOTES.md):
fx = fy = 0.5 H / tan(fovy / 2), cx = (W - 1) / 2, cy = (H - 1) / 2 in numpy pixel indices.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from cell.camera import CameraModel
from cell.sim import layout
from cell.sim.parts import COLLISION_GROUP
from cell.sim.sensor import SensorModel

__all__ = ["CameraRig", "Frame", "add_overhead_camera", "true_camera_model"]

_MJ_TO_CV = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True, eq=False)
class Frame:
    """One rendered view.

    ``rgb`` uint8 (H, W, 3) as the sensor delivers it; ``depth`` float32 (H, W), metres
    along the optical axis; ``seg`` int32 (H, W), the part id at each pixel (0: no part);
    ``camera`` the true ``CameraModel`` (intrinsics, distortion, pose) at render time.
    """

    rgb: np.ndarray
    depth: np.ndarray
    seg: np.ndarray
    camera: CameraModel


def add_overhead_camera(spec: mujoco.MjSpec, *, fovy: float) -> None:
    """The fixed camera ``overhead``: straight down on the pick zone, image +x = world +x.

    ``fovy`` is the vertical field of view in degrees.
    """
    pos = layout.PICK_ZONE + np.array([0.0, 0.0, layout.OVERHEAD_CAMERA_HEIGHT])
    spec.worldbody.add_camera(name="overhead", pos=pos.tolist(), quat=[1, 0, 0, 0], fovy=fovy)


def true_camera_model(
    model: mujoco.MjModel, data: mujoco.MjData, name: str, width: int, height: int,
    distortion: tuple[float, ...] = (0.0,) * 5,
) -> CameraModel:
    """The simulator's true camera model of camera ``name`` for a ``width`` x ``height`` image."""
    cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
    f = 0.5 * height / math.tan(math.radians(model.cam_fovy[cid]) / 2)
    K = np.array([[f, 0, (width - 1) / 2], [0, f, (height - 1) / 2], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = data.cam_xmat[cid].reshape(3, 3) @ _MJ_TO_CV
    T[:3, 3] = data.cam_xpos[cid]
    return CameraModel(width, height, K, np.array(distortion, dtype=np.float64), T)


class CameraRig:
    """Renders RGB, depth and segmentation of one camera through its sensor model.

    ``part_of_geom`` maps a geom id to its part id (0 for geoms that are not parts).
    Collision geoms (group 3) and sites are hidden, so segmentation shows what a camera
    sees of the parts.
    """

    def __init__(
        self, model: mujoco.MjModel, name: str, sensor: SensorModel, part_of_geom: np.ndarray
    ) -> None:
        self.name = name
        self.sensor = sensor
        self.part_of_geom = part_of_geom
        self._renderer = mujoco.Renderer(model, sensor.height, sensor.width)
        self._option = mujoco.MjvOption()
        self._option.geomgroup[COLLISION_GROUP] = 0
        self._option.sitegroup[:] = 0
        self._option.flags[mujoco.mjtVisFlag.mjVIS_RANGEFINDER] = 0

    def close(self) -> None:
        self._renderer.close()

    def render_rgb(self, data: mujoco.MjData) -> np.ndarray:
        """The ideal (pinhole, noise-free) RGB render, uint8 (H, W, 3)."""
        self._renderer.update_scene(data, camera=self.name, scene_option=self._option)
        return self._renderer.render()

    def render_depth(self, data: mujoco.MjData) -> np.ndarray:
        """Depth along the optical axis, float32 (H, W) metres, distorted like the image."""
        r = self._renderer
        r.update_scene(data, camera=self.name, scene_option=self._option)
        r.enable_depth_rendering()
        try:
            depth = r.render().astype(np.float32)
        finally:
            r.disable_depth_rendering()
        return self.sensor.warp(depth, nearest=True)

    def render_seg(self, data: mujoco.MjData) -> np.ndarray:
        """Part id per pixel, int32 (H, W), 0 where no part is seen."""
        r = self._renderer
        r.update_scene(data, camera=self.name, scene_option=self._option)
        r.enable_segmentation_rendering()
        try:
            raw = r.render()
        finally:
            r.disable_segmentation_rendering()
        obj, kind = raw[..., 0], raw[..., 1]
        is_geom = (kind == int(mujoco.mjtObj.mjOBJ_GEOM)) & (obj >= 0)
        seg = np.where(is_geom, self.part_of_geom[np.clip(obj, 0, None)], 0).astype(np.int32)
        return self.sensor.warp(seg, nearest=True)
