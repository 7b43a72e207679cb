"""``Replay``: a rerun recording (.rrd) of one run, to scrub through in the rerun viewer.

Open one with ``.venv/bin/rerun out/demo/replay.rrd``. Everything timed sits on the
timeline ``sim_time`` (simulated seconds); the cell's geometry and the camera are static.
Entity layout::

    world/bodies/<body>               the body's pose in the world (Transform3D): static for
                                      bodies fixed to the world, on sim_time for the arm's
                                      links and the parts (logged when they move)
    world/bodies/<body>/<geom>        each visible geom (not collision group 3, not fully
                                      transparent) in the body's frame: Boxes3D, Capsules3D,
                                      Cylinders3D, Ellipsoids3D (spheres) or Mesh3D, in its
                                      colour; unnamed geoms are named g<index>
    world/overhead_camera             the overhead camera's pose and intrinsics (Pinhole)
    world/overhead_camera/image       the camera image, JPEG
    world/overhead_camera/detections  the detections: 2D boxes labelled "kind material conf"
    truth/segmentation                the ground-truth part ids (SegmentationImage; labels
                                      "part_<id> <kind> <finish>" from truth's annotations)
    metrics/<name>                    one time series (Scalars) per metric
    events                            the run's text log (TextLog)

Parts waiting for their turn, parts caught past the belt's end and parts come to rest in a
bin float off stage (about 3 m out): they stay in the recording, away from the cell (a
binned part leaves its bin in the replay when it is parked). Body and geom names are
escaped where they hold a ``/`` (``arm/base`` is one path part).

The file is written to a temporary file beside ``path`` and renamed into place by
``close`` (``finish`` then ``commit``: a caller with other files to write finishes the
recording, writes them, and commits it last); ``abort`` (or an exception inside a
``with`` block) discards it, so a failed run never leaves a partial recording. The
recording id follows from the scenario's name and seed, so reruns of a scenario are the
same recording to the viewer.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import tempfile
import uuid
import weakref
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np
import rerun as rr

from cell.errors import JobError
from cell.files import file_mode
from cell.text import escape

if TYPE_CHECKING:
    from cell.camera import CameraModel
    from cell.sim import World

__all__ = ["TIMELINE", "Replay", "recording_id", "rerun_disabled"]

TIMELINE = "sim_time"
_COLLISION_GROUP = 3  # cell.sim.parts.COLLISION_GROUP
_PLANE_HALF = 1.5  # m: the half size drawn for an infinite plane
_STATE_BATCH = 250  # log_state calls buffered before they are sent
_MOVE_TOL = 1e-5  # m, and quaternion units: a body that moved less is not logged again
_DEFAULT_BOX_PX = 24.0  # the box drawn for a detection without a usable size
_MAT_COLOURS = {"metal": (110, 170, 255), "plastic": (255, 170, 40)}
_UNKNOWN_COLOUR = (255, 60, 60)
_LEVELS = {"warning": "WARN", "warn": "WARN", "information": "INFO"}
_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32)  # MuJoCo's geom default
_DRAWN = np.array(mujoco.MjvOption().geomgroup, dtype=bool)  # the geom groups MuJoCo draws by default
_G = mujoco.mjtGeom


class Replay:
    """A rerun recording of one run, saved to ``path`` (.rrd).

    ``jpeg_quality`` (1..100) of the camera images; ``plane_z`` (m) the height of the
    surface the parts lie on, for the size of the detection boxes (default: the
    scenario's ``vision.plane_z``). A ``JobError`` (a ``CellError``) naming ``path``
    when the file cannot be made (missing folder, a directory, ``RERUN=off``) or
    finished, and for any call after ``close`` or ``abort``.
    """

    def __init__(self, path: str | Path, world: World, *, jpeg_quality: int = 85,
                 plane_z: float | None = None, key: str = "") -> None:
        self.path = Path(path)
        if not 1 <= int(jpeg_quality) <= 100:
            raise JobError(f"replay {str(self.path)!r}: jpeg_quality must be in 1..100, got {jpeg_quality}")
        self._quality = int(jpeg_quality)
        self._plane_z = float(world.scenario.vision.plane_z if plane_z is None else plane_z)
        if rerun_disabled():  # (checked first: a disabled stream warns when it is dropped)
            raise JobError(f"replay {str(self.path)!r}: rerun logging is disabled (RERUN="
                           f"{escape(os.environ['RERUN'])} in the environment): unset it to write "
                           "a replay")
        self._rec = rr.RecordingStream("cell", recording_id=recording_id(world, key=key))
        if not self._rec.is_enabled():
            raise JobError(f"replay {str(self.path)!r}: rerun logging is disabled: "
                           "check the RERUN environment variable")
        self._tmp = _temporary_beside(self.path)
        self._finalizer = weakref.finalize(self, _discard, self._rec, self._tmp)
        self._moving = _moving_bodies(world.model)
        self._paths = [_body_path(world.model, int(b)) for b in self._moving]
        self._last = np.full((len(self._moving), 7), np.inf)  # the poses last logged
        self._states: list[tuple[float, np.ndarray, np.ndarray]] = []  # (t, bodies, poses) to send
        self._preset = ""
        self._finished = False
        try:
            self._rec.save(self._tmp)
            self._rec.set_log_time_enabled(False)  # sim_time is the one timeline
            self._rec.set_log_tick_enabled(False)
            self._rec.send_recording_name(f"{world.scenario.name} (seed {world.scenario.seed})")
            self._log_static(world)
            self.log_state(world.time, world)
        except Exception as exc:
            self._finalizer()
            raise JobError(f"replay {str(self.path)!r}: cannot write it: {exc}") from exc

    def __enter__(self) -> Replay:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    @property
    def closed(self) -> bool:
        """True after ``close``, ``finish`` or ``abort``: nothing more can be logged."""
        return self._finished or not self._finalizer.alive

    def log_state(self, t: float, world: World) -> None:
        """The poses of the bodies that move (arm links, parts) at simulated time ``t``;
        only those that moved by more than 10 um (or 1e-5 in a quaternion's
        components) since they were last logged. Buffered, and sent as one column per body
        every ``_STATE_BATCH`` calls and at ``close``: far cheaper than a log per body."""
        self._at(None)
        pose = np.hstack([world.data.xpos[self._moving], world.data.xquat[self._moving]])
        moved = np.flatnonzero(np.any(np.abs(pose - self._last) > _MOVE_TOL, axis=1))
        if moved.size:
            self._last[moved] = pose[moved]
            self._states.append((float(t), moved, pose[moved]))
        if len(self._states) >= _STATE_BATCH:
            self._send_states()

    def log_capture(self, t: float, *, rgb: np.ndarray, detections: list, seg: np.ndarray | None,
                    camera: CameraModel, preset: str = "") -> None:
        """One camera capture at ``t``: the image (JPEG), the detections as labelled boxes
        (``camera`` sizes them), the ground-truth segmentation when ``seg`` is given, and
        ``preset`` (e.g. the lighting preset) as an event when it changes."""
        self._at(t)
        rgb = np.ascontiguousarray(rgb)
        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise JobError(f"replay: rgb must be uint8 (H, W, 3), got {rgb.dtype} {rgb.shape}")
        self._rec.log("world/overhead_camera/image", rr.Image(rgb).compress(jpeg_quality=self._quality))
        self._rec.log("world/overhead_camera/detections", _boxes(detections, camera, self._plane_z))
        if seg is not None:
            self._rec.log("truth/segmentation", rr.SegmentationImage(np.asarray(seg, dtype=np.int32)))
        if preset and preset != self._preset:
            self._preset = preset
            self.log_event(t, f"preset {preset}")

    def log_metrics(self, t: float, metrics: dict[str, float | None]) -> None:
        """One point per metric under ``metrics/<name>``; None and non-finite values are skipped."""
        self._at(t)
        for name, value in metrics.items():
            if isinstance(value, (int, float, np.number)) and math.isfinite(value):
                self._rec.log(f"metrics/{rr.escape_entity_path_part(str(name))}", rr.Scalars(float(value)))

    def log_event(self, t: float, text: str, *, level: str = "info") -> None:
        """A line of the run's text log at ``t`` (``level``: debug, info, warn, error...)."""
        self._at(t)
        lvl = _LEVELS.get(level.lower(), level.upper())
        self._rec.log("events", rr.TextLog(str(text), level=lvl))

    def close(self) -> None:
        """Flush everything, finish the file and move it to ``path`` (atomically)."""
        self.finish()
        self.commit()

    def finish(self) -> None:
        """Flush everything and finish the file, still under its temporary name: ``commit``
        moves it to ``path``, ``abort`` discards it (as does forgetting it)."""
        self._at(None)
        try:
            self._send_states()
            self._rec.flush()
            self._rec.disconnect()  # drops the file sink: it writes its footer and closes
            if os.path.getsize(self._tmp) == 0:
                raise OSError("rerun wrote nothing")
            with open(self._tmp, "rb") as f:
                os.fsync(f.fileno())
            os.chmod(self._tmp, file_mode())  # as open() would make it, not 0600
        except Exception as exc:
            self._finalizer()
            raise JobError(f"replay {str(self.path)!r}: cannot finish it: {exc}") from exc
        self._finished = True

    def commit(self) -> None:
        """Move the finished file to ``path`` (atomically)."""
        if not self._finished or not self._finalizer.alive:
            raise JobError(f"replay {str(self.path)!r}: only a finished replay can be committed")
        try:
            os.replace(self._tmp, self.path)
        except OSError as exc:
            self._finalizer()
            raise JobError(f"replay {str(self.path)!r}: cannot move it into place: {exc}") from exc
        self._finalizer.detach()

    def abort(self) -> None:
        """Discard the recording: the temporary file goes, ``path`` is left as it was."""
        self._finalizer()

    def _at(self, t: float | None) -> None:
        """Checks the replay is open; sets the time ``t`` (None: leaves it)."""
        if self.closed:
            raise JobError(f"replay {str(self.path)!r} is already closed")
        if t is not None:
            self._rec.set_time(TIMELINE, duration=float(t))

    def _send_states(self) -> None:
        """Send the buffered poses: one column of each moved body's poses on sim_time."""
        if not self._states:
            return
        t = np.concatenate([np.full(len(i), t) for t, i, _ in self._states])
        body = np.concatenate([i for _, i, _ in self._states])
        pose = np.concatenate([p for *_, p in self._states])
        self._states.clear()
        for b in np.unique(body):
            rows = body == b
            self._rec.send_columns(self._paths[b], indexes=[rr.TimeColumn(TIMELINE, duration=t[rows])],
                                   columns=rr.Transform3D.columns(translation=pose[rows, :3],
                                                                  quaternion=pose[rows][:, [4, 5, 6, 3]]))

    def _log_static(self, world: World) -> None:
        m = world.model
        self._rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for body in range(1, m.nbody):
            if not np.isin(body, self._moving):
                self._rec.log(_body_path(m, body), _transform(world.data.xpos[body], world.data.xquat[body]),
                              static=True)
        for g in range(m.ngeom):
            shape, name = _geom_shape(m, g), rr.escape_entity_path_part(m.geom(g).name or f"g{g}")
            if shape is not None:
                self._rec.log(f"{_body_path(m, int(m.geom_bodyid[g]))}/{name}",
                              _transform(m.geom_pos[g], m.geom_quat[g]), shape, static=True)
        cam = world.camera_model("overhead")
        T = cam.T_world_camera
        self._rec.log("world/overhead_camera", rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                      rr.Pinhole(image_from_camera=cam.K, resolution=[cam.width, cam.height],
                                 image_plane_distance=0.2), static=True)
        labels = [rr.ClassDescription(info=rr.AnnotationInfo(0, "background", (0, 0, 0, 0)))]
        labels += [rr.ClassDescription(info=(p.id, f"part_{p.id} {p.kind} {p.finish}")) for p in world.parts]
        self._rec.log("truth", rr.AnnotationContext(labels), static=True)


def rerun_disabled() -> bool:
    """Whether the environment turns rerun's logging off: ``RERUN`` = ``0``, ``no``,
    ``off`` or ``false`` (any case), the values the rerun SDK reads as off."""
    return os.environ.get("RERUN", "").strip().lower() in ("0", "no", "off", "false")


def recording_id(world: World, *, key: str = "") -> str:
    """The recording id of a run of ``world``: a UUID from its whole scenario (every setting
    and the seed) and ``key`` (what else makes the run: the calibration it acts on). The
    viewer merges recordings of one id: two runs that differ in any setting must not."""
    scenario = json.dumps(dataclasses.asdict(world.scenario), sort_keys=True, default=str)
    return str(uuid.uuid5(uuid.NAMESPACE_URL, f"cell/{scenario}/{key}"))


def _temporary_beside(path: Path) -> str:
    """An empty temporary file in ``path``'s folder (checks the folder is writable)."""
    if path.is_dir():
        raise JobError(f"replay {str(path)!r} is a directory: give a file name (.rrd)")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise JobError(f"replay {str(path)!r}: cannot write in its folder: {exc.strerror or exc}") from None
    os.close(fd)
    return tmp


def _discard(rec: rr.RecordingStream, tmp: str) -> None:
    """Close the stream's file and remove it (abort, or a replay never closed). A folder
    that turned read-only keeps it: the error that stopped the run says what went wrong."""
    try:
        rec.disconnect()
    finally:
        with contextlib.suppress(OSError):
            Path(tmp).unlink(missing_ok=True)


def _moving_bodies(m: mujoco.MjModel) -> np.ndarray:
    """Ids of the bodies not welded to the world (jointed, free or mocap)."""
    return np.array([b for b in range(1, m.nbody) if m.body_weldid[b] != 0 or m.body_mocapid[b] >= 0],
                    dtype=np.int64)


def _body_path(m: mujoco.MjModel, body: int) -> str:
    name = m.body(body).name or f"body{body}"
    return f"world/bodies/{rr.escape_entity_path_part(name)}"


def _transform(pos: np.ndarray, quat_wxyz: np.ndarray) -> rr.Transform3D:
    w, x, y, z = (float(q) for q in quat_wxyz)
    return rr.Transform3D(translation=[float(p) for p in pos], quaternion=rr.Quaternion(xyzw=[x, y, z, w]))


def _geom_colour(m: mujoco.MjModel, g: int) -> np.ndarray:
    """The geom's RGBA as MuJoCo draws it: its material's unless its own rgba is set."""
    mat, rgba = int(m.geom_matid[g]), m.geom_rgba[g]
    return np.asarray(m.mat_rgba[mat] if mat >= 0 and np.allclose(rgba, _DEFAULT_RGBA) else rgba, float)


def _geom_shape(m: mujoco.MjModel, g: int):
    """The rerun archetype of geom ``g`` in its own frame, or None when it is not drawn."""
    group, rgba = int(m.geom_group[g]), _geom_colour(m, g)
    if group == _COLLISION_GROUP or not 0 <= group < len(_DRAWN) or not _DRAWN[group] or rgba[3] <= 0:
        return None
    colour = [np.round(rgba * 255).astype(np.uint8)]
    s, kind = m.geom_size[g], int(m.geom_type[g])
    if kind == _G.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[s], colors=colour, fill_mode="solid")
    if kind == _G.mjGEOM_PLANE:
        half = [s[0] or _PLANE_HALF, s[1] or _PLANE_HALF, 0.0005]
        return rr.Boxes3D(half_sizes=[half], centers=[[0, 0, -0.0005]], colors=colour, fill_mode="solid")
    if kind == _G.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(radii=[s[0]], colors=colour, fill_mode="solid")
    if kind == _G.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(half_sizes=[s], colors=colour, fill_mode="solid")
    if kind == _G.mjGEOM_CAPSULE:  # rerun's capsule starts at the origin, MuJoCo's is centred
        return rr.Capsules3D(lengths=[2 * s[1]], radii=[s[0]], translations=[[0, 0, -s[1]]], colors=colour)
    if kind == _G.mjGEOM_CYLINDER:
        return rr.Cylinders3D(lengths=[2 * s[1]], radii=[s[0]], colors=colour, fill_mode="solid")
    if kind == _G.mjGEOM_MESH:
        mesh = int(m.geom_dataid[g])
        v0, nv = m.mesh_vertadr[mesh], m.mesh_vertnum[mesh]
        f0, nf = m.mesh_faceadr[mesh], m.mesh_facenum[mesh]
        return rr.Mesh3D(vertex_positions=m.mesh_vert[v0:v0 + nv], triangle_indices=m.mesh_face[f0:f0 + nf],
                         albedo_factor=colour[0])
    return None  # height fields, SDFs: not drawn


def _boxes(detections: list, camera: CameraModel, plane_z: float) -> rr.Boxes2D:
    """Axis-aligned pixel boxes around each detection's footprint, centred on its centroid."""
    centres, sizes, labels, colours = [], [], [], []
    for d in detections:
        uv = getattr(d, "centroid", None)
        if uv is None or len(uv) != 2 or not np.all(np.isfinite(uv)):
            continue
        centres.append([float(uv[0]), float(uv[1])])
        sizes.append(_box_size(d, camera, plane_z))
        kind, material = getattr(d, "kind", "?"), getattr(d, "material", "?")
        conf = min(_number(d, "kind_confidence"), _number(d, "material_confidence"))
        labels.append(f"{kind} {material} {conf:.2f}" + (" partial" if getattr(d, "partial", False) else ""))
        colours.append(_MAT_COLOURS.get(material, _UNKNOWN_COLOUR))
    return rr.Boxes2D(centers=np.reshape(centres, (-1, 2)), sizes=np.reshape(sizes, (-1, 2)),
                      labels=labels, colors=np.reshape(colours, (-1, 3)).astype(np.uint8))


def _number(d, name: str) -> float:
    """``d.name`` as a float; 1.0 when missing or not a number."""
    try:
        return float(getattr(d, name, 1.0))
    except (TypeError, ValueError):
        return 1.0


def _box_size(d, camera: CameraModel, plane_z: float) -> list[float]:
    """The pixel extent of the footprint on the plane: its rectangle (length x width)
    turned by yaw where the kind's axes are the rectangle's (symmetry 1, 2, 4), else a
    square of the longer side (round, hexagonal and unknown parts: yaw says nothing)."""
    try:
        length, width = (float(v) for v in d.size)
        yaw = float(getattr(d, "yaw", 0.0) or 0.0)
        if getattr(d, "symmetry", 1) not in (1, 2, 4):
            length = width = max(length, width)
        centre = getattr(d, "position", None)
        if centre is None:  # the centroid's ray (no distortion) meets the plane
            ray = camera.T_world_camera[:3, :3] @ np.linalg.solve(camera.K, [*d.centroid, 1.0])
            o = camera.T_world_camera[:3, 3]
            centre = o[:2] + ray[:2] * (plane_z - o[2]) / ray[2]
        c, s = math.cos(yaw), math.sin(yaw)
        local = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]]) * [length / 2, width / 2]
        xy = np.asarray(centre, dtype=np.float64)[:2] + local @ np.array([[c, s], [-s, c]])
        px = camera.project(np.c_[xy, np.full(4, plane_z)])
        size = np.ptp(px, axis=0)
        if np.all(np.isfinite(size)) and np.all(size > 0):
            return [float(size[0]), float(size[1])]
    except (AttributeError, TypeError, ValueError, np.linalg.LinAlgError):
        pass
    return [_DEFAULT_BOX_PX, _DEFAULT_BOX_PX]
