"""The Ray backend: the same chunks as Ray tasks, on this machine or on a Ray cluster.

``ray.init()`` starts a local instance with ``workers`` CPUs, or ``address`` joins a
running cluster (``ray://HOST:10001``, ``HOST:6379`` or ``auto``), where every node must
have ``cell`` installed (``pip install 'cell[ray]'``) and ``MUJOCO_GL=egl`` working. The
task is :func:`cell.sweep.worker.run_chunk` itself, one CPU each; a worker process is
replaced after ``recycle`` tasks (``max_calls``) so memory stays flat. At most two tasks
per worker are in flight; results stream back with ``ray.wait`` as each finishes. Ray
retries a task whose worker died (three times); after that the sweep stops with a
``SweepError`` (finished rows are kept: ``--resume``). Ctrl-C cancels the tasks in flight.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from cell.sweep.errors import SweepError
from cell.sweep.worker import Chunk, Outcome, run_chunk
from cell.text import escape

__all__ = ["RayPool", "import_ray"]


def import_ray():
    """The ``ray`` module, or a ``SweepError`` saying how to install it. The process's state
    before Ray's first import is kept (importing it sets ``sys.excepthook`` and ``RAY_*``
    variables): :meth:`RayPool.close` puts it back."""
    global _BEFORE_RAY
    if "ray" not in sys.modules and _BEFORE_RAY is None:
        _BEFORE_RAY = _ProcessState.now()
    try:
        import ray
    except ImportError:
        raise SweepError("--backend ray needs Ray: pip install 'cell[ray]' (or "
                         "pip install 'ray>=2.60')") from None
    return ray


class RayPool:
    """Runs chunks as Ray tasks: a local instance of ``workers`` CPUs, or the cluster at
    ``address`` (then ``workers`` only bounds the tasks in flight: default, its CPUs).

    :meth:`start` starts or joins Ray (``run`` does when it is not started), :meth:`close`
    shuts down what ``start`` started; as a context manager it does both."""

    def __init__(self, workers: int | None, *, address: str | None = None, recycle: int = 100,
                 render_threads: int = 1) -> None:
        self.workers, self.address = workers, address
        self.recycle, self.render_threads = recycle, render_threads
        self._ray = None
        self._task = None
        self._started = False
        self._before: _ProcessState | None = None  # what ray.init changes, to put back

    def __enter__(self) -> RayPool:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self) -> None:
        """Start a local Ray instance or join the cluster (once)."""
        if self._ray is not None:
            return
        ray = import_ray()
        now = _ProcessState.now()
        first = _BEFORE_RAY or now  # (environment and excepthook as before Ray's import)
        before = _ProcessState(first.environ, first.excepthook, now.handlers)
        if not ray.is_initialized():
            options = {"include_dashboard": False, "log_to_driver": False,
                       "logging_level": logging.ERROR}
            self._before = before
            try:
                if self.address is None:
                    ray.init(num_cpus=self.workers, **options)
                else:
                    ray.init(address=self.address, **options)
            except Exception as exc:  # ConnectionError, ValueError, RuntimeError, ...
                self._before.restore()
                where = "start a local Ray instance" if self.address is None else \
                    f"join the Ray cluster at {escape(repr(self.address))}"
                raise SweepError(f"--backend ray: cannot {where}: {escape(type(exc).__name__)}: "
                                 f"{escape(' '.join(str(exc).split())[:300])}") from None
            self._before.restore_signals()  # (Ctrl-C and SIGTERM stay the command's)
            self._started = True
        self._ray = ray
        self._task = ray.remote(num_cpus=1, max_calls=self.recycle)(run_chunk)
        if self.workers is None:
            self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))

    def close(self) -> None:
        """Shut Ray down if :meth:`start` started it."""
        if self._started and self._ray is not None:
            self._ray.shutdown()
            if self._before is not None:
                self._before.restore()
        self._ray, self._task, self._started, self._before = None, None, False, None

    def run(self, chunks: Iterable[Chunk], on_outcomes: Callable[[tuple[Outcome, ...]], None]) -> None:
        """Run every chunk; ``on_outcomes`` is called in this thread as each one finishes."""
        self.start()
        ray, task = self._ray, self._task
        flying: list = []
        try:
            source = iter(chunks)
            while True:
                while len(flying) < 2 * self.workers:
                    chunk = next(source, None)
                    if chunk is None:
                        break
                    flying.append(task.remote(chunk, self.render_threads))
                if not flying:
                    break
                done, flying = ray.wait(flying, num_returns=1)
                try:
                    outcomes = ray.get(done[0])
                except ray.exceptions.RayTaskError as exc:
                    cause = exc.cause if isinstance(getattr(exc, "cause", None), Exception) else None
                    raise (cause or exc) from None
                except ray.exceptions.RayError as exc:
                    raise SweepError(f"a Ray task failed ({escape(type(exc).__name__)}: a worker "
                                     "died, or the cluster lost a node); the finished runs are "
                                     "kept: run the sweep again with --resume") from None
                on_outcomes(outcomes)
        except BaseException:
            for ref in flying:
                ray.cancel(ref, force=True)
            raise


@dataclass(frozen=True)
class _ProcessState:
    """What importing Ray and ``ray.init`` change in the driver's process and leave so
    after ``shutdown``: the environment's ``RAY_*`` and ``PYTHONBREAKPOINT`` (pointing at
    Ray's debugger, which turns a later ``breakpoint()`` into an error line; other
    variables are the caller's own business), ``sys.excepthook`` and the SIGINT and
    SIGTERM handlers."""

    environ: dict
    excepthook: object
    handlers: dict

    @classmethod
    def now(cls) -> _ProcessState:
        handlers = {}
        if threading.current_thread() is threading.main_thread():
            handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
        return cls(dict(os.environ), sys.excepthook, handlers)

    def restore_signals(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return  # (only the main thread may set handlers)
        for s, handler in self.handlers.items():
            if handler is not None:
                signal.signal(s, handler)

    def restore(self) -> None:
        for key in [k for k in os.environ if _rays(k) and k not in self.environ]:
            del os.environ[key]
        os.environ.update({k: v for k, v in self.environ.items() if _rays(k)})
        sys.excepthook = self.excepthook
        self.restore_signals()


def _rays(key: str) -> bool:
    """An environment variable Ray sets in the driver."""
    return key.startswith("RAY_") or key == "PYTHONBREAKPOINT"


_BEFORE_RAY: _ProcessState | None = None  # the process before Ray's first import
