"""Calibration files: versioned JSON, written atomically, every field checked on loading.

Layout (``"schema": "cell.calibration"``, ``"version": 1``)::

    {"schema": "cell.calibration", "version": 1,
     "cameras": [{"name": "wrist", "width": 640, "height": 480,
                  "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], "dist": [k1, k2, p1, p2, k3],
                  "T_flange_camera": [[...4x4...]],   # or "T_base_camera" (a fixed camera)
                  "rms": 0.04, "method": "PARK+refined", "scenario": "sort", "seed": 1000}]}

Units: pixels for ``K`` and ``rms`` (the reprojection RMS of the intrinsics the entry
holds, over all corners of the views used: the intrinsic calibration's, or for an overhead
entry whose refinement freed the intrinsics, the refinement's), metres for translations.
The robot's base frame is the cell's world frame: the arm's base stands at the world
origin with its axes aligned (``cell.sim.layout.ARM_BASE``, a surveyed transform of the
cell, not a calibrated one), so a fixed camera's ``T_world_camera`` is its
``T_base_camera``. Loading checks everything: the schema and version, each key
(missing, unknown, or both poses), the camera fields as :class:`cell.camera.CameraModel`
checks them (finite, shapes, focal lengths, principal point, distortion and translation
in their ranges, rotations orthonormal with det +1), ``rms``
finite and >= 0, names, method and scenario printable text, ``seed`` an integer >= 0.
A failure is a ``CalibrationError`` that names the file, the camera and the field.
Writing goes to a temporary file beside the target, is flushed to disk (``fsync``), read
back and checked, and only then renamed over the target, so a reader never sees half a file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell.camera import CameraModel, check_camera_fields, check_pose, read_json_file
from cell.errors import CalibrationError
from cell.files import StagedFiles
from cell.text import show

__all__ = ["SCHEMA", "VERSION", "CalibrationFile", "CameraCalibration",
           "calibration_from_dict", "load_calibration", "stage_calibration", "write_calibration"]

SCHEMA = "cell.calibration"
VERSION = 1
POSE_KEYS = ("T_flange_camera", "T_base_camera")  # eye-in-hand, fixed camera
_KEYS = ("name", "width", "height", "K", "dist", "rms", "method", "scenario", "seed")
_MAX_TEXT = 200


@dataclass(frozen=True, eq=False)
class CameraCalibration:
    """One calibrated camera: ``name``, image ``width`` x ``height`` (px), ``K`` (3x3, px),
    ``dist`` (5,), ``pose`` (4x4, m) named ``pose_name`` (``T_flange_camera`` for a wrist
    camera, ``T_base_camera`` for a fixed one), ``rms`` reprojection error (px), the
    ``method`` that gave the pose, and the ``scenario`` name and ``seed`` it came from.
    Every field is checked when the object is made (``CalibrationError``)."""

    name: str
    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    pose_name: str
    pose: np.ndarray
    rms: float
    method: str
    scenario: str
    seed: int

    def __post_init__(self) -> None:
        _text("name", self.name, limit=64)
        if self.pose_name not in POSE_KEYS:
            raise CalibrationError(f"camera {self.name!r}: pose must be one of {', '.join(POSE_KEYS)}, "
                                   f"got {self.pose_name!r}")
        try:
            f = check_camera_fields(self.width, self.height, self.K, self.dist, self.pose,
                                    pose_name=self.pose_name)
        except CalibrationError as exc:
            raise CalibrationError(f"camera {self.name!r}: {exc}") from None
        for key, value in (("width", f.width), ("height", f.height), ("K", f.K), ("dist", f.dist),
                           ("pose", f.pose)):
            object.__setattr__(self, key, value)
        object.__setattr__(self, "rms", _rms(self.name, self.rms))
        for key in ("method", "scenario"):
            _text(f"camera {self.name!r}: '{key}'", getattr(self, key))
        if not isinstance(self.seed, int | np.integer) or isinstance(self.seed, bool) or self.seed < 0:
            raise CalibrationError(f"camera {self.name!r}: 'seed' must be an integer >= 0, got "
                                   f"{show(self.seed)}")
        object.__setattr__(self, "seed", int(self.seed))

    def to_dict(self) -> dict:
        """The file's layout of this camera (plain lists and numbers)."""
        return {"name": self.name, "width": self.width, "height": self.height, "K": self.K.tolist(),
                "dist": self.dist.tolist(), self.pose_name: self.pose.tolist(), "rms": self.rms,
                "method": self.method, "scenario": self.scenario, "seed": self.seed}

    def camera_model(self, *, T_base_flange: np.ndarray | None = None) -> CameraModel:
        """The ``CameraModel`` of this camera (world = base frame). A wrist camera needs the
        flange pose of the moment, ``T_base_flange`` (4x4, m); a fixed camera takes none."""
        if self.pose_name == "T_base_camera":
            if T_base_flange is not None:
                raise CalibrationError(f"camera {self.name!r} is fixed (T_base_camera): it takes no "
                                       "flange pose")
            T_world_camera = self.pose
        else:
            if T_base_flange is None:
                raise CalibrationError(
                    f"camera {self.name!r} rides on the arm (T_flange_camera): its pose in the cell "
                    "depends on the arm's pose, so it needs the flange pose at the time of the image "
                    "(T_base_flange); only a fixed camera (e.g. 'overhead') works without one")
            try:
                T_base_flange = check_pose("T_base_flange", T_base_flange)
            except CalibrationError as exc:
                raise CalibrationError(f"camera {self.name!r}: {exc}") from None
            T_world_camera = T_base_flange @ self.pose
        return CameraModel(self.width, self.height, self.K.copy(), self.dist.copy(), T_world_camera)


@dataclass(frozen=True, eq=False)
class CalibrationFile:
    """The cameras of one calibration file, each name once."""

    cameras: tuple[CameraCalibration, ...]

    def __post_init__(self) -> None:
        names = [c.name for c in self.cameras]
        if not names:
            raise CalibrationError("a calibration holds at least one camera")
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise CalibrationError(f"camera {dup[0]!r} appears more than once")

    @property
    def names(self) -> tuple[str, ...]:
        """The cameras' names, in file order."""
        return tuple(c.name for c in self.cameras)

    def camera(self, name: str) -> CameraCalibration:
        """The camera called ``name``; ``CalibrationError`` listing the names otherwise."""
        for c in self.cameras:
            if c.name == name:
                return c
        raise CalibrationError(f"no camera {name!r} in the calibration; it has: {', '.join(self.names)}")

    def to_dict(self) -> dict:
        """The file's JSON layout (schema, version, cameras)."""
        return {"schema": SCHEMA, "version": VERSION, "cameras": [c.to_dict() for c in self.cameras]}


def _text(what: str, value: object, *, limit: int = _MAX_TEXT) -> None:
    if not isinstance(value, str) or not value or len(value) > limit or not value.isprintable():
        raise CalibrationError(f"{what} must be printable text of 1 to {limit} characters, got "
                               f"{show(value)}")


def _rms(name: str, value: object) -> float:
    ok = isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool)
    try:
        number = float(value) if ok else float("nan")
    except OverflowError:
        number = float("inf")
    if not (np.isfinite(number) and number >= 0):
        raise CalibrationError(f"camera {name!r}: 'rms' must be a finite number >= 0 (px), got "
                               f"{show(value)}")
    return number


def _camera_from_dict(data: object, index: int) -> CameraCalibration:
    label = f"cameras[{index}]"
    if not isinstance(data, dict):
        raise CalibrationError(f"{label} must be an object, got {type(data).__name__}")
    if isinstance(data.get("name"), str) and data["name"].isprintable():
        label += f" ({data['name']!r})"
    poses = [k for k in POSE_KEYS if k in data]
    missing = [k for k in _KEYS if k not in data] + ([" or ".join(POSE_KEYS)] if not poses else [])
    if missing:
        raise CalibrationError(f"{label}: missing key '{missing[0]}'")
    if len(poses) > 1:
        raise CalibrationError(f"{label}: has both {' and '.join(POSE_KEYS)}; a camera is either on "
                               "the flange or fixed")
    unknown = sorted(str(k) for k in data if k not in _KEYS + POSE_KEYS)
    if unknown:
        raise CalibrationError(f"{label}: unknown key {show(unknown[0])}; valid: "
                               f"{', '.join(_KEYS + POSE_KEYS)}")
    try:
        return CameraCalibration(
            name=data["name"], width=data["width"], height=data["height"], K=data["K"],
            dist=data["dist"], pose_name=poses[0], pose=data[poses[0]], rms=data["rms"],
            method=data["method"], scenario=data["scenario"], seed=data["seed"])
    except CalibrationError as exc:  # its message names the camera already
        raise CalibrationError(f"cameras[{index}]: {exc}") from None


def calibration_from_dict(data: object, *, where: str = "calibration") -> CalibrationFile:
    """A ``CalibrationFile`` from the JSON layout; ``CalibrationError`` starting with
    ``where`` and naming the problem otherwise."""
    try:
        if not isinstance(data, dict):
            raise CalibrationError(f"expected a JSON object with schema, version and cameras, got "
                                   f"{type(data).__name__}")
        for key in ("schema", "version", "cameras"):
            if key not in data:
                raise CalibrationError(f"missing key '{key}'")
        if data["schema"] != SCHEMA:
            raise CalibrationError(f"'schema' must be {SCHEMA!r}, got {show(data['schema'])}: not a "
                                   "calibration file")
        version = data["version"]
        if not isinstance(version, int) or isinstance(version, bool) or version != VERSION:
            raise CalibrationError(f"unsupported 'version' {show(version)}: this cell reads version "
                                   f"{VERSION}")
        unknown = sorted(str(k) for k in data if k not in ("schema", "version", "cameras"))
        if unknown:
            raise CalibrationError(f"unknown key {show(unknown[0])}; valid: schema, version, cameras")
        cams = data["cameras"]
        if not isinstance(cams, list):
            raise CalibrationError(f"'cameras' must be a list, got {type(cams).__name__}")
        return CalibrationFile(tuple(_camera_from_dict(c, i) for i, c in enumerate(cams)))
    except CalibrationError as exc:
        raise CalibrationError(f"{where}: {exc}") from None


def load_calibration(path: str | Path) -> CalibrationFile:
    """Read and check a calibration file (see the module docstring)."""
    path = Path(path)
    data = read_json_file(path, kind="calibration file")
    return calibration_from_dict(data, where=f"calibration file {str(path)!r}")


def write_calibration(path: str | Path, calibration: CalibrationFile) -> None:
    """Write ``calibration`` to ``path`` atomically: a temporary file in the same folder,
    flushed and fsynced, read back and checked, then renamed over ``path``."""
    with StagedFiles() as files:
        stage_calibration(files, path, calibration)
        files.commit(error=CalibrationError)


def stage_calibration(files: StagedFiles, path: str | Path, calibration: CalibrationFile) -> None:
    """Stage ``calibration`` for ``path`` among ``files`` (written by their commit, with
    the files that belong with it), read back and checked as :func:`write_calibration`."""
    text = json.dumps(calibration.to_dict(), indent=2, allow_nan=False) + "\n"

    def check(tmp: str) -> None:
        if load_calibration(tmp).to_dict() != calibration.to_dict():
            raise CalibrationError(f"calibration file {str(path)!r}: the written file reads back "
                                   "differently")

    files.add(path, text.encode("utf-8"), check=check, kind="calibration file",
              error=CalibrationError)
