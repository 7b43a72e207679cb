"""``cell.sweep``: parameter sweeps over scenario fields and seeds, on a local pool or Ray.

A sweep file (:mod:`cell.sweep.spec`) names a study, a base scenario, a job and a grid;
:mod:`cell.sweep.plan` resolves it into runs, :mod:`cell.sweep.runner` runs them on a
backend (:mod:`cell.sweep.local`, :mod:`cell.sweep.raybackend`) and appends each to
``results.csv`` (:mod:`cell.sweep.results`), and :mod:`cell.sweep.reports` draws the
study's plots and writes ``summary.md``. The jobs a run can do are in
:mod:`cell.sweep.jobs`. Names load lazily, on first use.
"""

from __future__ import annotations

from cell.lazy import lazy_names

_WHERE = {
    "Axis": "grid",
    "Case": "spec",
    "Chunk": "worker",
    "Columns": "plan",
    "JOBS": "jobs",
    "LocalPool": "local",
    "Outcome": "worker",
    "Plan": "plan",
    "REPORTS": "reports",
    "RayPool": "raybackend",
    "Run": "plan",
    "Scene": "scene",
    "Task": "worker",
    "SweepError": "errors",
    "SweepInterrupted": "runner",
    "SweepOptions": "runner",
    "SweepRun": "runner",
    "SweepSpec": "spec",
    "load_sweep": "spec",
    "make_backend": "runner",
    "make_chunks": "runner",
    "open_results": "results",
    "plan_sweep": "plan",
    "read_rows": "results",
    "render_scene": "scene",
    "run_chunk": "worker",
    "run_plan": "runner",
    "run_sweep": "runner",
    "score_frame": "scoring",
    "sweep_from_dict": "spec",
    "write_report": "reports",
}

__all__ = sorted(_WHERE)

__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
