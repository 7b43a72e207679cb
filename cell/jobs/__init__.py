"""``cell.jobs``: what the commands run: the sort job (``cell run``) and the snapshot.

Names load lazily, on first use: loading a scenario reads :mod:`cell.jobs.settings` and
must not import the simulator, the robot or the detector.
"""

from __future__ import annotations

import importlib

_WHERE = {
    "CaptureSettings": "settings",
    "FaultSettings": "settings",
    "SortSettings": "settings",
    "SortLoop": "loop",
    "SortRun": "sort",
    "run_sort": "sort",
    "overhead_model": "sort",
    "Capture": "eye",
    "Eye": "eye",
    "PickRecord": "score",
    "Scorekeeper": "score",
    "choose_bin": "policy",
    "pick_candidates": "policy",
    "load_detector": "detectors",
    "draw_detections": "report",
    "summary_table": "report",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module 'cell.jobs' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"cell.jobs.{_WHERE[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__
