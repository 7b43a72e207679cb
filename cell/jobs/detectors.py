"""Which detector a job uses: ``vision.detector`` = ``parts`` (ours) or ``package.module:Class``.

A detector is any object with ``detect(image, camera) -> list[Detection]`` (image uint8
RGB (H, W, 3), camera a :class:`~cell.camera.CameraModel`). A user's class is built with
the scenario's :class:`~cell.vision.settings.VisionSettings` when its constructor's first
parameter asks for it (named ``settings``, or positional with no default), else with none
(a ``min_area=60`` stays 60; keyword-only and ``**kwargs`` parameters keep their
defaults). ``examples/threshold_detector.py`` is such a class built from the syllabus
functions.

A user's detector is called through :class:`CheckedDetector`: whatever its ``detect``
raises becomes a ``JobError`` naming it, and what it returns must be what ours returns, a
list of :class:`~cell.vision.detector.Detection` with known kind and material names,
confidences in 0..1, finite numbers and the centroid in the image; anything else is a
``JobError`` naming the detector, the detection and what is wrong with it.
"""

from __future__ import annotations

import importlib
import inspect
import math
import numbers
from dataclasses import dataclass

import numpy as np

from cell.catalogue import KINDS
from cell.errors import CellError, JobError
from cell.text import escape, show
from cell.vision.detector import Detection
from cell.vision.settings import VisionSettings

__all__ = ["CheckedDetector", "checked_detections", "load_detector"]

_MATERIALS = ("metal", "plastic", "unknown")
_KINDS = (*KINDS, "unknown")


def load_detector(settings: VisionSettings) -> object:
    """The detector named by ``settings.detector``, built (a user's class wrapped in a
    :class:`CheckedDetector`); ``JobError`` naming it if it does not import, is not a
    class, cannot be built or has no ``detect`` method."""
    name = settings.detector
    if name == "parts":
        from cell.vision.detector import PartDetector

        return PartDetector(settings)
    shown = escape(repr(name))
    module_name, _, class_name = name.partition(":")
    try:
        module = importlib.import_module(module_name)
    except Exception as exc:  # an ImportError, or whatever the user's module raised
        raise JobError(f"vision.detector {shown}: cannot import module "
                       f"{escape(repr(module_name))}: {escape(type(exc).__name__)}: "
                       f"{escape(str(exc))}") from None
    cls = getattr(module, class_name, None)
    if not inspect.isclass(cls):
        raise JobError(f"vision.detector {shown}: module {escape(repr(module_name))} has no "
                       f"class {escape(repr(class_name))}")
    if not callable(getattr(cls, "detect", None)):
        raise JobError(f"vision.detector {shown}: class {escape(repr(class_name))} has no "
                       "detect(image, camera) method")
    try:
        detector = cls(settings) if _wants_settings(cls) else cls()
    except CellError:
        raise
    except Exception as exc:
        raise JobError(f"vision.detector {shown}: building it failed: "
                       f"{escape(type(exc).__name__)}: {escape(str(exc))}") from None
    return CheckedDetector(name, detector)


def _wants_settings(cls: type) -> bool:
    """Whether ``cls``'s constructor asks for the settings: its first parameter is named
    ``settings``, or takes a positional argument and has no default (``*args`` too)."""
    params = list(inspect.signature(cls).parameters.values())
    if not params:
        return False
    first = params[0]
    if first.name == "settings" and first.kind != inspect.Parameter.KEYWORD_ONLY:
        return True
    if first.kind == inspect.Parameter.VAR_POSITIONAL:
        return True
    positional = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    return first.kind in positional and first.default is inspect.Parameter.empty


@dataclass(frozen=True, eq=False)
class CheckedDetector:
    """A user's ``detector`` (``vision.detector`` = ``name``), called so that it cannot
    crash a job: see the module docstring."""

    name: str
    detector: object

    def detect(self, image: np.ndarray, camera: object) -> list[Detection]:
        """The detector's detections of ``image``, checked (``JobError`` naming it)."""
        try:
            found = self.detector.detect(image, camera)
        except Exception as exc:  # whatever the user's code raised, CellErrors included
            raise JobError(f"vision.detector {escape(repr(self.name))}: detect failed: "
                           f"{escape(type(exc).__name__)}: {escape(str(exc))}") from None
        return checked_detections(found, self.name, image_size=(image.shape[1], image.shape[0]))


def checked_detections(found: object, name: str, *, image_size: tuple[int, int]) -> list[Detection]:
    """``found`` (what detector ``name`` returned for an image of ``image_size`` (W, H)
    px) as a list of plain :class:`Detection` (numbers as ``int``/``float``); a
    ``JobError`` naming the detector and the first thing wrong when it is not a list of
    Detections with valid names, confidences in 0..1, finite numbers and the centroid in
    the image."""
    shown = escape(repr(name))
    if not isinstance(found, (list, tuple)):
        raise JobError(f"vision.detector {shown}: detect returned {escape(type(found).__name__)}, "
                       "not a list of Detection")
    out = []
    for k, det in enumerate(found, 1):
        where = f"vision.detector {shown}: detection {k} of {len(found)}"
        if not isinstance(det, Detection):
            raise JobError(f"{where} is {escape(type(det).__name__)}, not a Detection")
        try:
            out.append(_checked(det, image_size))
        except ValueError as exc:
            raise JobError(f"{where}: {exc}") from None
    return out


def _checked(d: Detection, image_size: tuple[int, int]) -> Detection:
    """``d`` with plain numbers; ``ValueError`` saying what is wrong with it."""
    width, height = image_size
    u, v = _pair(d.centroid, "centroid")
    if not (0 <= u <= width and 0 <= v <= height):
        raise ValueError(f"centroid {show(d.centroid)} lies outside the {width}x{height} image")
    return Detection(
        id=_integer(d.id, "id"), material=_name(d.material, "material", _MATERIALS),
        material_confidence=_number(d.material_confidence, "material_confidence", 0.0, 1.0),
        kind=_name(d.kind, "kind", _KINDS),
        kind_confidence=_number(d.kind_confidence, "kind_confidence", 0.0, 1.0),
        centroid=(u, v), yaw=_number(d.yaw, "yaw"), symmetry=_integer(d.symmetry, "symmetry"),
        position=None if d.position is None else _pair(d.position, "position"),
        size=_pair(d.size, "size", 0.0), partial=_flag(d.partial, "partial"),
        defect=_flag(d.defect, "defect"))


def _number(value: object, what: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """``value`` as a float when it is a finite real number in ``lo..hi``."""
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        x = float(value)
        if math.isfinite(x) and lo <= x <= hi:
            return x
    span = f" in {lo:g}..{hi:g}" if math.isfinite(lo) and math.isfinite(hi) else (
        f" >= {lo:g}" if math.isfinite(lo) else "")
    raise ValueError(f"{what} must be a finite number{span}, got {show(value)}")


def _pair(value: object, what: str, lo: float = -math.inf) -> tuple[float, float]:
    """``value`` as two floats when it is two finite real numbers (each ``>= lo``)."""
    if isinstance(value, (tuple, list, np.ndarray)) and len(value) == 2:
        try:
            return _number(value[0], what, lo), _number(value[1], what, lo)
        except ValueError:
            pass
    floor = f", each >= {lo:g}" if math.isfinite(lo) else ""
    raise ValueError(f"{what} must be two finite numbers{floor}, got {show(value)}")


def _integer(value: object, what: str) -> int:
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)) and value >= 0:
        return int(value)
    raise ValueError(f"{what} must be a whole number >= 0, got {show(value)}")


def _name(value: object, what: str, choices: tuple[str, ...]) -> str:
    if isinstance(value, str) and value in choices:
        return choices[choices.index(value)]
    raise ValueError(f"{what} must be one of {', '.join(choices)}, got {show(value)}")


def _flag(value: object, what: str) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ValueError(f"{what} must be True or False, got {show(value)}")
