"""What a worker process runs: chunks of runs that share a rendered scene.

A :class:`Chunk` is some runs of one job with the same scene key; :func:`run_chunk`
renders the scene once (a worker keeps the last ``SCENES_KEPT`` scenes) and measures each
run on it, returning one :class:`Outcome` per run. A run that fails on purpose (a
``CellError``: a detector that does not load or raises, parts that do not fit the view, a
pick the robot cannot make) is an outcome with its message on one line, escaped, so one
bad point does not stop a long sweep. Any other exception is a bug in ``cell`` and
propagates, with a note naming the job and the run: the sweep stops loudly (traceback,
exit status 1) and keeps its finished rows, so once the bug is fixed ``--resume`` does
that run and the rest. (Were a bug a failed row, it would hide in the ``error`` column,
and ``--resume`` would count the run as done and never do it again.)

The same function runs in the local pool's processes and as a Ray task. On first use in
a process it pins OpenCV to one thread and the software renderer (llvmpipe) to
``LP_NUM_THREADS`` threads (``init_process``): a sweep is parallel across runs, and
threads beyond the cores only contend. Every figure is converted to a plain ``int``,
``float`` or ``None`` (NaN and infinity become ``None``).
"""

from __future__ import annotations

import math
import os
import signal
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

from cell.errors import CellError
from cell.text import escape

__all__ = ["SCENES_KEPT", "Chunk", "Outcome", "Task", "init_process", "run_chunk", "run_tasks"]

SCENES_KEPT = 2
_SCENES: OrderedDict = OrderedDict()
_READY = {"done": False}


@dataclass(frozen=True)
class Task:
    """One run to do: its ``run_id``, ``scenario`` and job ``settings``."""

    run_id: str
    scenario: Any
    settings: Any


@dataclass(frozen=True)
class Chunk:
    """Runs of ``job`` that share one scene (or, for a job without scenes, one run)."""

    job: str
    tasks: tuple[Task, ...]


@dataclass(frozen=True)
class Outcome:
    """A finished run: its ``run_id``, its ``figures`` (metric and timing name -> number or
    None) and ``error``: None, or the one-line reason it failed (figures then empty)."""

    run_id: str
    figures: dict
    error: str | None


def init_process(render_threads: int | None = None, *, quiet_interrupt: bool = False) -> None:
    """Prepare this process for runs (once): headless EGL rendering, one OpenCV thread,
    ``render_threads`` llvmpipe threads (default: ``LP_NUM_THREADS`` as set, else 1).
    ``quiet_interrupt`` (the local pool's workers): Ctrl-C ends the process at once and
    silently; the parent reports the interruption."""
    if quiet_interrupt:
        signal.signal(signal.SIGINT, lambda *_: os._exit(130))
    if _READY["done"]:
        return
    os.environ.setdefault("MUJOCO_GL", "egl")
    if render_threads is not None:
        os.environ["LP_NUM_THREADS"] = str(render_threads)
    else:
        os.environ.setdefault("LP_NUM_THREADS", "1")
    import cv2

    cv2.setNumThreads(1)
    _READY["done"] = True


def _number(name: str, value: Any) -> int | float | None:
    if value is None:
        return None
    if isinstance(value, bool):
        return int(value)
    if hasattr(value, "item"):  # a numpy scalar
        value = value.item()
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    raise TypeError(f"figure {name!r} is {type(value).__name__}, not a number")


def _message(exc: CellError) -> str:
    """The reason a run failed: ``exc``'s message on one line, escaped (it may echo user
    text: a detector's own message, a file name)."""
    return escape(" ".join(str(exc).split())) or type(exc).__name__


def _scene(module: Any, key: Any, task: Task) -> Any:
    if key in _SCENES:
        _SCENES.move_to_end(key)
        return _SCENES[key]
    scene = module.prepare(task.scenario, task.settings)
    _SCENES[key] = scene
    while len(_SCENES) > SCENES_KEPT:
        _SCENES.popitem(last=False)
    return scene


def run_chunk(chunk: Chunk, render_threads: int | None = None) -> tuple[Outcome, ...]:
    """Prepare this process (:func:`init_process`) and run every task of ``chunk``; one
    :class:`Outcome` per task, in order."""
    init_process(render_threads)
    return run_tasks(chunk)


def run_tasks(chunk: Chunk) -> tuple[Outcome, ...]:
    """Run every task of ``chunk`` in this process as it is; one :class:`Outcome` per task."""
    from cell.sweep.jobs import job_module

    module = job_module(chunk.job)
    names = (*module.METRICS, *module.TIMINGS)
    out = []
    for task in chunk.tasks:
        try:
            key = module.scene_key(task.scenario, task.settings)
            scene = _scene(module, key, task) if key is not None else None
            figures = module.measure(scene, task.scenario, task.settings)
        except CellError as exc:
            out.append(Outcome(task.run_id, {}, _message(exc)))
            continue
        except Exception as exc:
            exc.add_note(f"cell sweep: run {task.run_id} (job {chunk.job!r}) stopped the sweep with "
                         "this unexpected error (a bug); the finished runs are kept, and --resume "
                         "does the rest once it is fixed")
            raise
        extra = set(figures) - set(names)
        if extra:
            raise TypeError(f"job {chunk.job!r} returned figures it does not declare: {sorted(extra)}")
        out.append(Outcome(task.run_id, {n: _number(n, figures.get(n)) for n in names}, None))
    return tuple(out)
