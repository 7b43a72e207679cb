"""Running a sweep: plan the runs, skip the finished ones, run the rest, write the report.

:func:`run_sweep` reads the sweep file, resolves its runs (:mod:`cell.sweep.plan`), opens
``results.csv`` in the output folder (reading back the finished runs with ``resume``),
groups the runs still to do into chunks that share a rendered scene (at most
``chunk_runs`` runs each), runs them on the chosen backend and appends one row per run
as each chunk comes back, then regenerates the plots and ``summary.md`` from
``results.csv``. A ``KeyboardInterrupt`` stops the workers and propagates after the file
is closed: every finished row is in it, and ``resume`` does only the rest.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from cell.sweep.errors import SweepError
from cell.sweep.jobs import job_module
from cell.sweep.output import RESULTS, prepare_out, remove_temporaries, sweep_lock
from cell.sweep.plan import Plan, Run, param_value, plan_sweep
from cell.sweep.progress import Progress
from cell.sweep.results import open_results, read_rows
from cell.sweep.spec import load_sweep
from cell.sweep.worker import Chunk, Outcome, Task
from cell.text import escape

__all__ = ["BACKENDS", "SweepInterrupted", "SweepOptions", "SweepRun", "make_backend", "make_chunks",
           "output_files", "run_plan", "run_sweep"]

BACKENDS = ("local", "ray")


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM stopped a sweep: ``done`` of ``total`` runs are in ``path``
    (results.csv); ``by`` is the interrupt that stopped it (a ``KeyboardInterrupt``)."""

    def __init__(self, done: int, total: int, path: Path, by: BaseException | None = None) -> None:
        super().__init__(f"{done} of {total} runs done")
        self.done, self.total, self.path, self.by = done, total, path, by


@dataclass(frozen=True)
class SweepOptions:
    """How to run a sweep: ``backend`` (``local`` or ``ray``), ``workers`` (None: the
    machine's CPUs, or the cluster's), Ray's ``address`` (None: a local instance),
    ``resume`` an existing ``results.csv``, ``progress`` (None: when stderr is a terminal),
    ``recycle`` (chunks a worker runs before it is replaced), ``chunk_runs`` (runs per
    chunk at most), ``report`` (write plots and summary.md at the end)."""

    backend: str = "local"
    workers: int | None = None
    address: str | None = None
    resume: bool = False
    progress: bool | None = None
    recycle: int = 100
    chunk_runs: int = 24
    report: bool = True

    def __post_init__(self) -> None:
        if self.backend not in BACKENDS:
            raise SweepError(f"SweepOptions: backend {self.backend!r} unknown; valid: "
                             f"{', '.join(BACKENDS)}")
        for name, lo in (("workers", 1), ("recycle", 1), ("chunk_runs", 1)):
            value = getattr(self, name)
            if value is None and name == "workers":
                continue
            if isinstance(value, bool) or not isinstance(value, int) or value < lo:
                raise SweepError(f"SweepOptions: {name} must be an integer >= {lo}"
                                 f"{' (or None: every CPU)' if name == 'workers' else ''}, got "
                                 f"{value!r}")


@dataclass(frozen=True)
class SweepRun:
    """What a sweep did: the output folder, the ``total`` runs of the grid, ``resumed``
    (already in results.csv), ``ran`` now, ``failed`` of those, ``cut_bytes`` of a
    half-written row dropped on resume, the report's ``files``, the ``wall_s`` and
    ``failed_before``: the resumed runs whose rows hold an error (a failed run is a
    result: ``--resume`` does not run it again)."""

    out: Path
    total: int
    resumed: int
    ran: int
    failed: int
    cut_bytes: int
    files: tuple[str, ...]
    wall_s: float
    failed_before: int = 0


def make_chunks(runs: list[Run], *, chunk_runs: int) -> Iterator[Chunk]:
    """The runs grouped by (job, scene key), in order of first appearance, at most
    ``chunk_runs`` per chunk; a job without scenes has one run per chunk."""
    groups: dict[object, list[Run]] = {}
    for run in runs:
        key = job_module(run.job).scene_key(run.scenario, run.settings)
        groups.setdefault((run.job, key) if key is not None else (run.job, run.run_id), []).append(run)
    for (job, _), members in groups.items():
        for i in range(0, len(members), chunk_runs):
            part = members[i:i + chunk_runs]
            yield Chunk(job, tuple(Task(r.run_id, r.scenario, r.settings) for r in part))


def _row(plan: Plan, run: Run, outcome: Outcome) -> dict:
    row = {"run_id": run.run_id, "job": run.job, "seed": run.scenario.seed}
    for key in plan.columns.params:
        row[key] = param_value(run, key)
    row.update(outcome.figures)
    row["error"] = outcome.error
    return row


def make_backend(options: SweepOptions):
    """The backend ``options`` ask for (not started)."""
    workers = options.workers
    if options.backend == "local":
        from cell.sweep.local import LocalPool

        workers = workers or os.cpu_count() or 1
        return LocalPool(workers, recycle=options.recycle, render_threads=1)
    if options.backend == "ray":
        from cell.sweep.raybackend import RayPool, import_ray

        import_ray()  # fail before any run if Ray is missing
        if workers is None and options.address is None:
            workers = os.cpu_count() or 1
        return RayPool(workers, address=options.address, recycle=options.recycle, render_threads=1)
    raise SweepError(f"unknown backend {escape(repr(options.backend))}; valid: {', '.join(BACKENDS)}")


def run_plan(plan: Plan, out: Path, options: SweepOptions, *, backend: object | None = None) -> SweepRun:
    """Run the runs of ``plan`` not yet in ``out``/results.csv (see the module docstring);
    ``out`` must exist (:func:`run_sweep` makes it).

    ``backend``: a started backend to use (left running); default: one made from
    ``options``, closed at the end. The folder is locked meanwhile (:func:`sweep_lock`):
    a second sweep there stops with one line instead of running the runs again."""
    with sweep_lock(out):
        return _run_plan(plan, out, options, backend)


def _run_plan(plan: Plan, out: Path, options: SweepOptions, backend: object | None) -> SweepRun:
    """:func:`run_plan`, its folder locked."""
    t0 = time.perf_counter()
    own = backend is None
    backend = make_backend(options) if own else backend
    results, cut = open_results(out / RESULTS, plan.columns.names, {r.run_id for r in plan.runs},
                                numbers=plan.columns.numbers)
    remove_temporaries(out)
    todo = [r for r in plan.runs if r.run_id not in results.done]
    by_id = {r.run_id: r for r in todo}
    resumed = len(plan.runs) - len(todo)
    progress = Progress(len(plan.runs), resumed, enabled=options.progress)
    counts = {"ran": 0, "failed": 0}

    def finished(outcomes: tuple[Outcome, ...]) -> None:
        for outcome in outcomes:
            results.append(_row(plan, by_id[outcome.run_id], outcome))
            counts["ran"] += 1
            counts["failed"] += outcome.error is not None
        progress.advance(len(outcomes))

    progress.advance(0)
    try:
        if todo:
            backend.run(make_chunks(todo, chunk_runs=options.chunk_runs), finished)
    except KeyboardInterrupt as stop:
        results.close()
        raise SweepInterrupted(results.count(), len(plan.runs), results.path, stop) from None
    finally:
        results.close()
        progress.close()
        if own:
            backend.close()
    files: tuple[str, ...] = ()
    if options.report:
        from cell.sweep.reports import write_report

        files = write_report(plan, out)
    before = 0
    if resumed:
        _, rows = read_rows(out / RESULTS)
        earlier = {r.run_id for r in plan.runs} - set(by_id)
        before = sum(1 for r in rows if r.get("error") and r.get("run_id") in earlier)
    return SweepRun(out, len(plan.runs), resumed, counts["ran"], counts["failed"], cut, files,
                    time.perf_counter() - t0, before)


def run_sweep(path: str | Path, *, out: str, options: SweepOptions | None = None) -> SweepRun:
    """Run the sweep file ``path`` into the folder ``out``."""
    options = options or SweepOptions()
    plan = plan_sweep(load_sweep(path))
    if options.backend == "ray":
        from cell.sweep.raybackend import import_ray

        import_ray()  # a missing Ray fails before --out is made
    return run_plan(plan, prepare_out(out, resume=options.resume, files=output_files(plan, options)),
                    options)


def output_files(plan: Plan, options: SweepOptions) -> tuple[str, ...]:
    """The names of the files the sweep writes into its output folder."""
    if not options.report:
        return (RESULTS,)
    from cell.sweep.reports import report_files

    return (RESULTS, *report_files(plan.spec.report))
