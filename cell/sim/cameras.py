"""Cameras: the fixed overhead camera, true camera models, and rendering to a ``Frame``.

MuJoCo cameras look along their frame's -z with +y up; OpenCV cameras look along +z with
+y down. ``true_camera_model`` converts one to the other: the OpenCV camera's rotation is
MuJoCo's times diag(1, -1, -1). Intrinsics follow from ``fovy`` (NOTES.md):
fx = fy = 0.5 H / tan(fovy / 2), cx = (W - 1) / 2, cy = (H - 1) / 2 in numpy pixel indices.

Segmentation: MuJoCo's renderer gives, per pixel, an (object id, object type) pair,
int32 (H, W, 2): type 5 (``mjOBJ_GEOM``) for geoms, 6 for sites (which share id numbers
with geoms), other types for other decorations, and (-1, -1) for the background.
``part_ids`` turns it into part ids with one lookup table and one ``np.take`` (about
0.3 ms at 640x480 on a 2-core CPU instead of 1.2 ms for masks and ``np.where``): the two
int32 of a pixel, read as one little-endian int64, are ``id + type * 2**32`` (for
id >= 0), so subtracting ``GEOM * 2**32`` leaves the geom id for geom pixels and, for
every other pixel, a number outside 0..ngeom - 1; ``np.take(..., mode="clip")`` sends
those to a 0 at either end of the table.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass

import mujoco
import numpy as np

from cell.camera import CameraModel
from cell.errors import SimError
from cell.sim import layout
from cell.sim.parts import COLLISION_GROUP
from cell.sim.sensor import SensorModel

__all__ = ["CameraRig", "Frame", "add_overhead_camera", "part_ids", "part_lut", "true_camera_model"]

_MJ_TO_CV = np.diag([1.0, -1.0, -1.0])
_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)
_LITTLE_ENDIAN = sys.byteorder == "little"


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


def part_lut(part_of_geom: np.ndarray) -> np.ndarray:
    """The lookup table of ``part_ids``: int32 (ngeom + 2,), ``[0, *part_of_geom, 0]``.

    ``part_of_geom`` (int, (ngeom,)) is the part id of each geom, 0 for geoms that are not
    parts; entry g + 1 of the table is geom g's part, the 0 at each end the sentinel for
    every pixel that is not a geom.
    """
    return np.concatenate([[0], np.asarray(part_of_geom).ravel(), [0]]).astype(np.int32)


def _pixel_keys(raw: np.ndarray, *, little_endian: bool = _LITTLE_ENDIAN) -> np.ndarray:
    """One int64 per pixel of MuJoCo's raw segmentation, (H, W): ``id + type * 2**32``.

    ``raw`` is int32 (H, W, 2), (object id, object type) per pixel. On a little-endian
    CPU this is a view of ``raw`` (no copy); a negative id gives ``id + (type + 1) * 2**32``
    there, still no geom's key.
    """
    if little_endian:
        return np.ascontiguousarray(raw, dtype=np.int32).view(np.int64)[..., 0]
    return raw[..., 0].astype(np.int64) + (raw[..., 1].astype(np.int64) << 32)


def part_ids(raw: np.ndarray, lut: np.ndarray, *, little_endian: bool = _LITTLE_ENDIAN) -> np.ndarray:
    """Part id per pixel, int32 (H, W), from MuJoCo's raw segmentation int32 (H, W, 2).

    ``lut`` is ``part_lut(part_of_geom)``. Pixels of geoms get their part's id (0 for geoms
    that are not parts); sites, other objects and the background get 0.
    """
    index = _pixel_keys(raw, little_endian=little_endian) - (_GEOM * 2**32 - 1)  # geom g -> g + 1
    return np.take(lut, index, mode="clip")


class CameraRig:
    """Renders RGB, depth and segmentation of one camera through its sensor model.

    ``part_of_geom`` maps a geom id to its part id (0 for geoms that are not parts); it is
    read once, here, into the lookup table of ``part_ids``. Collision geoms (group 3) and
    sites are hidden, so segmentation shows what a camera sees of the parts.
    """

    def __init__(
        self, model: mujoco.MjModel, name: str, sensor: SensorModel, part_of_geom: np.ndarray
    ) -> None:
        self.name = name
        self.sensor = sensor
        self.part_of_geom = part_of_geom
        self._lut = part_lut(part_of_geom)
        # a distorting lens sees beyond the pinhole view: the ideal render reaches that far
        # (sensor.padding), with the same focal length, so the camera's field of view grows
        self._model, self._id = model, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        px, py = sensor.padding()
        height, width = sensor.height + 2 * py, sensor.width + 2 * px
        f = 0.5 * sensor.height / math.tan(math.radians(model.cam_fovy[self._id]) / 2)
        self._fovy = math.degrees(2 * math.atan(0.5 * height / f)) if py else None
        glob = model.vis.global_
        glob.offwidth, glob.offheight = max(glob.offwidth, width), max(glob.offheight, height)
        try:
            self._renderer = mujoco.Renderer(model, height, width)
        except mujoco.FatalError as exc:
            if "OpenGL platform library has not been loaded" not in str(exc):
                raise
            raise SimError(
                "MuJoCo cannot render: it chose its OpenGL backend when it was imported, "
                f"before MUJOCO_GL was set (now {os.environ.get('MUJOCO_GL')!r}); set "
                "MUJOCO_GL=egl in the environment, or import cell before mujoco (and mink)"
            ) from None
        self._option = mujoco.MjvOption()
        self._option.geomgroup[COLLISION_GROUP] = 0
        self._option.sitegroup[:] = 0
        self._option.flags[mujoco.mjtVisFlag.mjVIS_RANGEFINDER] = 0

    def close(self) -> None:
        self._renderer.close()

    def _update(self, data: mujoco.MjData) -> None:
        """The renderer's scene from ``data``, through the camera widened by the padding."""
        if self._fovy is None:  # (no padding: the camera as it is)
            self._renderer.update_scene(data, camera=self.name, scene_option=self._option)
            return
        fovy = self._model.cam_fovy[self._id]
        self._model.cam_fovy[self._id] = self._fovy
        try:
            self._renderer.update_scene(data, camera=self.name, scene_option=self._option)
        finally:
            self._model.cam_fovy[self._id] = fovy

    def render_rgb(self, data: mujoco.MjData) -> np.ndarray:
        """The ideal (pinhole, noise-free) RGB render, uint8 (H, W, 3), and with lens
        distortion ``sensor.padding()`` larger on each side."""
        self._update(data)
        return self._renderer.render()

    def render_depth(self, data: mujoco.MjData) -> np.ndarray:
        """Depth along the optical axis, float32 (H, W) metres, distorted like the image."""
        r = self._renderer
        self._update(data)
        r.enable_depth_rendering()
        try:
            depth = r.render().astype(np.float32)
        finally:
            r.disable_depth_rendering()
        return self.sensor.warp(depth, nearest=True)

    def render_seg_raw(self, data: mujoco.MjData) -> np.ndarray:
        """MuJoCo's segmentation: int32 (H, W, 2), (object id, object type) per pixel, of
        the ideal render (``sensor.padding()`` larger on each side with lens distortion)."""
        r = self._renderer
        self._update(data)
        r.enable_segmentation_rendering()
        try:
            return r.render()
        finally:
            r.disable_segmentation_rendering()

    def part_ids(self, raw: np.ndarray) -> np.ndarray:
        """Part id per pixel, int32 (H, W), of a raw segmentation (undistorted; 0: no part)."""
        return part_ids(raw, self._lut)

    def render_seg(self, data: mujoco.MjData) -> np.ndarray:
        """Part id per pixel, int32 (H, W), 0 where no part is seen, distorted like the image."""
        return self.sensor.warp(self.part_ids(self.render_seg_raw(data)), nearest=True)
