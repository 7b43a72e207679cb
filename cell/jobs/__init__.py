"""``cell.jobs``: what the commands run: the sort job (``cell run``) and the snapshot.

Names load lazily, on first use: loading a scenario reads :mod:`cell.jobs.settings` and
must not import the simulator, the robot or the detector.
"""

from __future__ import annotations

from cell.lazy import lazy_names

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
    "merge_materials": "eye",
    "PickRecord": "score",
    "Scorekeeper": "score",
    "choose_bin": "policy",
    "pick_candidates": "policy",
    "load_detector": "detectors",
    "draw_detections": "report",
    "summary_table": "report",
}

__all__ = sorted(_WHERE)

__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
