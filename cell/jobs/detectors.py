"""Which detector a job uses: ``vision.detector`` = ``parts`` (ours) or ``package.module:Class``.

A detector is any object with ``detect(image, camera) -> list[Detection]`` (image uint8
RGB (H, W, 3), camera a :class:`~cell.camera.CameraModel`). A user's class is built with
the scenario's :class:`~cell.vision.settings.VisionSettings` when its constructor takes
one argument, else with none. ``examples/threshold_detector.py`` is such a class built
from the syllabus functions.
"""

from __future__ import annotations

import importlib
import inspect

from cell.config import escape
from cell.errors import CellError, JobError
from cell.vision.settings import VisionSettings

__all__ = ["load_detector"]


def load_detector(settings: VisionSettings) -> object:
    """The detector named by ``settings.detector``, built; ``JobError`` naming it if it
    does not import, is not a class, cannot be built or has no ``detect`` method."""
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
        takes_settings = len(inspect.signature(cls).parameters) >= 1
        return cls(settings) if takes_settings else cls()
    except CellError:
        raise
    except Exception as exc:
        raise JobError(f"vision.detector {shown}: building it failed: "
                       f"{escape(type(exc).__name__)}: {escape(str(exc))}") from None
