"""``cell detect IMAGE --camera camera.json``: run the part detector on any image.

The camera file is the ``camera.json`` that ``cell snapshot`` writes (width, height, K,
dist, T_world_camera in OpenCV axes), or a user's own with the same keys, or a
calibration file that ``cell calibrate`` writes, with ``--camera-name NAME`` to pick its
camera (a fixed camera: a wrist camera's pose depends on the arm's, which an image file
does not carry). A lossy JPEG (subsampled chroma, or quantisation coarser than quality
98's) is detected with a warning on stderr and under ``warnings`` in the JSON: its
artefacts cost parts and materials (the README's compression study). Detector
settings come from the ``[vision]`` section of ``--scenario FILE`` (defaults without
one), then ``--set key=value`` overrides: ``vision.segmentation=otsu``, or simply
``segmentation=otsu`` (a key of the vision section needs no prefix). ``--set`` takes
vision settings only: a key of another section (``parts.count``) is refused.

Parts are looked for on the belt, in the camera file's world frame (the cell's): on the
plane ``vision.plane_z`` high, between world y = ``vision.belt_y`` (a part's centre at
least 4 mm inside); a camera of another set-up needs both set.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math
import os
import stat
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
from PIL import Image, JpegImagePlugin, UnidentifiedImageError

from cell.calib.calfile import SCHEMA
from cell.camera import CameraModel, read_json_file
from cell.errors import CalibrationError, ScenarioError, VisionError
from cell.options import Parser
from cell.scenario import load_scenario, scenario_from_dict
from cell.text import escape, override_source
from cell.vision.detector import PartDetector
from cell.vision.settings import VisionSettings

__all__ = ["MAX_PIXELS", "main"]

MAX_PIXELS = 50_000_000  # the largest image decoded (8K is 33 Mpx): bigger is refused unread
_VISION_KEYS = tuple(sorted(f.name for f in dataclasses.fields(VisionSettings)))  # what --set takes
_KEY_SHOWN = 60  # characters of a refused --set key echoed in its message


def _parser() -> Parser:
    p = Parser(
        prog="cell detect", description=__doc__.splitlines()[0],
        epilog="Parts are looked for on the belt, in the camera file's world frame (the cell's): "
        "on the plane vision.plane_z high, between world y = vision.belt_y (a part's centre at least "
        "4 mm inside); a camera of another set-up needs both set (--set plane_z=... --set "
        "belt_y=[low,high]).")
    p.add_argument("image", help="image file (PNG, JPEG, ...), read as RGB; its size must be the "
                   f"camera's, at most {MAX_PIXELS:,} pixels")
    p.add_argument("--camera", required=True,
                   help="camera.json with K, dist, T_world_camera; or a calibration file with --camera-name")
    p.add_argument("--camera-name", default=None, metavar="NAME",
                   help="the camera to use from a calibration file (cell calibrate --out)")
    p.add_argument("--scenario", default=None, help="scenario TOML whose [vision] section to use")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a vision setting (KEY=VALUE or vision.KEY=VALUE; repeatable), KEY one "
                   f"of: {', '.join(_VISION_KEYS)}")
    p.add_argument("--json", action="store_true", help="print the detections as JSON")
    return p


def _qualify(assignment: str) -> str:
    """A ``--set`` of a vision setting as the scenario's key: ``KEY=VALUE`` becomes
    ``vision.KEY=VALUE``; ``vision.KEY=VALUE`` is kept (the scenario checks KEY and the
    value). Text without ``=``, or the key of any other section, is a ``ScenarioError``."""
    where = override_source(assignment)
    if "=" not in assignment:
        raise ScenarioError(f"{where}: expected KEY=VALUE, e.g. --set segmentation=otsu")
    key = assignment.partition("=")[0].strip()
    if key in _VISION_KEYS:
        return f"vision.{assignment.strip()}"
    if key == "vision" or key.startswith("vision."):
        return assignment
    shown = escape(key) if len(key) <= _KEY_SHOWN else escape(key[: _KEY_SHOWN - 3]) + "..."
    raise ScenarioError(f"{where}: key '{shown}' is not a vision setting; cell detect --set "
                        f"takes keys of the [vision] section only (KEY=VALUE or vision.KEY=VALUE), "
                        f"KEY one of: {', '.join(_VISION_KEYS)}")


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)  # errors are ours to report
    overrides = [_qualify(a) for a in args.overrides]
    if args.scenario:
        scenario = load_scenario(args.scenario, overrides=overrides)
    else:
        scenario = scenario_from_dict({}, overrides=overrides)
    camera = _camera(args.camera, args.camera_name)
    path = Path(args.image)
    rgb, warnings = _read_image(path, camera)
    for warning in warnings:
        print(f"cell detect: warning: {warning}", file=sys.stderr)
    detector = PartDetector(scenario.vision)
    t0 = time.perf_counter()
    detections = detector.detect(rgb, camera)
    ms = (time.perf_counter() - t0) * 1e3
    _check_finite(detections)
    if args.json:
        print(json.dumps({"image": str(path), "latency_ms": ms, "warnings": warnings,
                          "detections": [d.to_dict() for d in detections]}, indent=2, allow_nan=False))
        return 0
    print(f"{_shown(path)}: {len(detections)} detection(s) in {ms:.1f} ms")
    if detections:
        print(f"{'id':>3} {'kind':<11} {'conf':>5} {'material':<8} {'conf':>5} "
              f"{'u':>7} {'v':>7} {'x mm':>8} {'y mm':>8} {'yaw deg':>8} {'partial':>7}")
    for d in detections:
        x, y = ("-", "-") if d.position is None else (f"{d.position[0] * 1e3:.1f}",
                                                      f"{d.position[1] * 1e3:.1f}")
        print(f"{d.id:>3} {d.kind:<11} {d.kind_confidence:>5.2f} {d.material:<8} "
              f"{d.material_confidence:>5.2f} {d.centroid[0]:>7.1f} {d.centroid[1]:>7.1f} "
              f"{x:>8} {y:>8} {d.yaw * 57.29578:>8.1f} {str(d.partial):>7}")
    return 0


def _camera(path: str, name: str | None) -> CameraModel:
    """The camera model of ``--camera`` (and ``--camera-name`` for a calibration file)."""
    if name is not None:
        return CameraModel.from_calibration(path, name)
    data = read_json_file(path, kind="camera file")
    if isinstance(data, dict) and data.get("schema") == SCHEMA:
        names = [c.get("name") for c in data.get("cameras", []) if isinstance(c, dict)] \
            if isinstance(data.get("cameras"), list) else []
        shown = ", ".join(repr(n) for n in names if isinstance(n, str)) or "none"
        raise CalibrationError(f"camera file {path!r} is a calibration file: name its camera with "
                               f"--camera-name (cameras in it: {shown})")
    return CameraModel.from_dict(data, where=f"camera file {path!r}")


_GREY_MODES = ("1", "L", "LA", "La", "I", "I;16", "I;16B", "I;16L", "I;16N", "F")  # Pillow's


def _read_image(path: Path, camera: CameraModel) -> tuple[np.ndarray, list[str]]:
    """The image at ``path`` as uint8 RGB, its size checked against ``camera`` before
    decoding, and warnings about it (a lossy JPEG, :func:`_jpeg_warning`). A grey image is
    refused (the detector tells metal from plastic, and shadows from parts, by colour); an
    EXIF orientation is not applied (the pixels as the camera took them: the camera model
    describes those)."""
    _check_image_file(path)
    (w, h), mode, jpeg = _header(path)
    if mode in _GREY_MODES:
        raise VisionError(f"image file {str(path)!r} is a grey image (mode {mode}): the detector "
                          "needs colour (RGB), which tells metal from plastic and a shadow from a part")
    if (w, h) != (camera.width, camera.height):
        raise VisionError(f"image file {str(path)!r} is {w}x{h} pixels, the camera's is "
                          f"{camera.width}x{camera.height}")
    if w * h > MAX_PIXELS:
        raise VisionError(f"image file {str(path)!r} is {w}x{h} pixels ({w * h:,}), more than "
                          f"the {MAX_PIXELS:,} this command decodes (camera {camera.width}x{camera.height})")
    with _c_stderr() as said:  # libpng writes its errors to stderr itself, past OpenCV's logging
        # (decoded from memory: a path that is not UTF-8 would crash cv2.imread)
        bgr = cv2.imdecode(np.frombuffer(_image_bytes(path), np.uint8),
                           cv2.IMREAD_COLOR | cv2.IMREAD_IGNORE_ORIENTATION)
    if bgr is None:
        why = " ".join(said.read().split())[:120] or "damaged or truncated?"
        raise VisionError(f"image file {str(path)!r}: cannot decode the image ({_plain(why)})")
    warning = _jpeg_warning(path, *jpeg) if jpeg is not None else None
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), [warning] if warning else []


_JPEG_SAMPLING = {1: "4:2:2", 2: "4:2:0"}  # Pillow's get_sampling codes of subsampled chroma
_FINE_STEP = 5  # a JPEG's largest quantisation step at quality 98 (the IJG tables)


def _jpeg_warning(path: Path, sampling: int, step: int) -> str | None:
    """Why a JPEG's pixels are not what the detector is measured on (None: they nearly
    are): chroma subsampled (``sampling``, Pillow's code) or quantisation steps coarser
    than quality 98's (``step``, the largest in its tables). The compression study
    (README, *What the studies found*) measured the loss."""
    why = []
    if sampling in _JPEG_SAMPLING:
        why.append(f"{_JPEG_SAMPLING[sampling]} chroma")
    if step > _FINE_STEP:
        why.append(f"quantisation steps up to {step}, coarser than quality 98's")
    if not why:
        return None
    return (f"image file {str(path)!r} is a lossy JPEG ({', '.join(why)}): its artefacts move "
            "outlines and fake or hide a metal's grain, so parts are missed and materials "
            "misread; the detector keeps its figures on lossless frames (PNG) or JPEG of "
            "4:4:4 chroma from quality 98")


@contextlib.contextmanager
def _c_stderr() -> Iterator[io.StringIO]:
    """What C code writes to file descriptor 2 meanwhile, kept off the terminal; read it after."""
    said = io.StringIO()
    sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no stderr at all: nothing to keep off it
        yield said
        return
    try:
        with tempfile.TemporaryFile() as sink:
            os.dup2(sink.fileno(), 2)
            try:
                yield said
            finally:
                os.dup2(saved, 2)
                sink.seek(0)
                said.write(sink.read(4096).decode("utf-8", "replace"))
                said.seek(0)
    finally:
        os.close(saved)


def _check_image_file(path: Path) -> None:
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise VisionError(f"no such image file: {str(path)!r}") from None
    except OSError as exc:
        raise VisionError(f"image file {str(path)!r}: cannot read it ({exc.strerror})") from None
    if stat.S_ISDIR(mode):
        raise VisionError(f"image file {str(path)!r} is a directory, not an image")
    if not stat.S_ISREG(mode):
        raise VisionError(f"image file {str(path)!r} is not a regular file")


def _image_bytes(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError as exc:
        raise VisionError(f"image file {str(path)!r}: cannot read it ({exc.strerror})") from None


def _header(path: Path) -> tuple[tuple[int, int], str, tuple[int, int] | None]:
    """(width, height), Pillow's mode and, for a JPEG, (its chroma sampling as Pillow's
    ``get_sampling`` codes it, its largest quantisation step), else None, from the image
    file's header; the pixels are not decoded.

    Pillow's own decompression-bomb limit is lifted for this read (it would refuse a
    huge image without saying its size); ``MAX_PIXELS`` is checked by the caller.
    """
    limit, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None
    try:
        with Image.open(path) as im:
            jpeg = None
            if isinstance(im, JpegImagePlugin.JpegImageFile):  # (MPO too: JPEG frames)
                tables = getattr(im, "quantization", None) or {}
                jpeg = (JpegImagePlugin.get_sampling(im),
                        max((max(t) for t in tables.values() if len(t)), default=0))
            return im.size, im.mode, jpeg
    except UnidentifiedImageError:
        raise VisionError(f"image file {str(path)!r} is not an image (PNG, JPEG, ...) or its "
                          f"format is unknown") from None
    except (OSError, SyntaxError, ValueError) as exc:  # unreadable, or a damaged header
        reason = getattr(exc, "strerror", None) or str(exc)
        raise VisionError(f"image file {str(path)!r}: cannot read its header ({_plain(reason)})") from None
    finally:
        Image.MAX_IMAGE_PIXELS = limit


def _check_finite(detections: list) -> None:
    """A non-finite number in a detection is refused: no output ever carries NaN or inf."""
    for d in detections:
        for key, value in d.to_dict().items():
            numbers = value if isinstance(value, list) else [value]
            if any(isinstance(v, float) and not math.isfinite(v) for v in numbers):
                raise VisionError(f"detection {d.id}: '{key}' is {value}, not a finite number "
                                  f"(degenerate [vision] settings?)")


def _shown(path: Path) -> str:
    """The path as typed, or escaped (``repr``) where it holds non-printable characters."""
    return _plain(str(path))


def _plain(text: str) -> str:
    """``text``, or its ``repr`` (non-printable characters escaped) where it holds any."""
    return text if text.isprintable() else repr(text)
