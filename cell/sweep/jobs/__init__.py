"""What one run of a sweep does: the jobs a sweep file can name.

A job is a module with:

- ``Settings``: a frozen settings dataclass (fields declared with
  :func:`cell.config.setting`) holding the job's own parameters, the ``[job]`` section of a
  sweep file (``job.codec`` in a grid); every field has a default;
- ``METRICS``: the names of the figures it measures (CSV columns), and ``TIMINGS``: those
  that are wall times (they differ from run to run; every other figure is a function of
  the scenario, the settings and the seed on one machine);
- ``scene_key(scenario, settings)``: a hashable key of what the run renders (runs with the
  same key share one rendered scene), or ``None`` when each run renders its own;
- ``prepare(scenario, settings)``: the scene (rendered once per key, in a worker);
- ``measure(scene, scenario, settings) -> dict``: the figures (``METRICS``, ``TIMINGS``; a
  figure with no samples is ``None``). Ground truth is read only to score.

``JOBS`` maps each name to its module; :func:`job_module` imports one.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from cell.sweep.errors import SweepError
from cell.text import escape

__all__ = ["JOBS", "job_module"]

JOBS: dict[str, str] = {
    "detect": "cell.sweep.jobs.detect",
    "sort": "cell.sweep.jobs.sort",
    "compress": "cell.sweep.jobs.compress",
    "smooth": "cell.sweep.jobs.smooth",
    "match": "cell.sweep.jobs.match",
    "edges": "cell.sweep.jobs.edges",
}


def job_module(name: str) -> ModuleType:
    """The module of job ``name``; ``SweepError`` listing the jobs if there is none."""
    if name not in JOBS:
        raise SweepError(f"unknown job {escape(repr(name))}; valid: {', '.join(JOBS)}")
    return importlib.import_module(JOBS[name])
