"""The local backend: a pool of worker processes on this machine.

``concurrent.futures.ProcessPoolExecutor`` with the ``spawn`` start method (a worker
never inherits the parent's MuJoCo or EGL state; forked GL contexts misbehave), each
worker replaced after ``recycle`` chunks (``max_tasks_per_child``) so memory stays flat
over a long sweep. At most two chunks per worker are in flight; the rest wait in the
plan, so the parent holds no more than that. Results come back as each chunk finishes.

A worker that dies (killed, out of memory) breaks the pool: the chunks it had not
returned are submitted again to a fresh pool (a line on stderr says so), up to
``MAX_RESTARTS`` times in one sweep, then the sweep stops with a ``SweepError`` (finished
rows are kept: ``--resume``). Ctrl-C stops the workers at once (their unfinished chunks
are lost, never half written) and re-raises ``KeyboardInterrupt``. A worker whose parent
is gone without closing the pool (``kill -9``) ends within a second.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from cell.sweep.errors import SweepError
from cell.sweep.worker import Chunk, Outcome, init_process, run_chunk

__all__ = ["MAX_RESTARTS", "LocalPool"]

MAX_RESTARTS = 3


def _init(render_threads: int, parent: int) -> None:
    init_process(render_threads, quiet_interrupt=True)
    threading.Thread(target=_exit_with, args=(parent,), name="cell-parent-watch",
                     daemon=True).start()


def _exit_with(parent: int) -> None:
    """End this worker within a second of its parent process (pid ``parent``) ending
    without closing the pool (``kill -9``, the out-of-memory killer): a worker inherits
    both ends of the pool's queues, so it never sees them close, and it held the sweep's
    stdout open (``cell sweep ... | tee log`` did not end)."""
    while os.getppid() == parent:
        time.sleep(1.0)
    os._exit(1)


class LocalPool:
    """Runs chunks on ``workers`` local processes; ``render_threads`` llvmpipe threads each.

    :meth:`start` makes the pool (``run`` does when it is not started), :meth:`close` ends
    it; as a context manager it does both."""

    def __init__(self, workers: int, *, recycle: int = 100, render_threads: int = 1) -> None:
        self.workers, self.recycle, self.render_threads = workers, recycle, render_threads
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> LocalPool:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop(kill=exc[0] is not None)

    def start(self) -> None:
        """Make the pool (its processes start with the first chunks)."""
        if self._pool is None:
            self._start()

    def close(self) -> None:
        """Wait for the workers to finish and end them."""
        self._stop(kill=False)

    def _start(self) -> ProcessPoolExecutor:
        self._pool = ProcessPoolExecutor(
            max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
            initializer=_init, initargs=(self.render_threads, os.getpid()),
            max_tasks_per_child=self.recycle)
        return self._pool

    def _stop(self, *, kill: bool) -> None:
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if kill:
            # ProcessPoolExecutor has no public way to stop a running task (3.14 adds
            # terminate_workers); its processes are in ``_processes``.
            processes = list(getattr(pool, "_processes", {}).values())
            manager = getattr(pool, "_executor_manager_thread", None)
            pool.shutdown(wait=False, cancel_futures=True)
            for p in processes:
                if p.is_alive():
                    p.terminate()
            for p in processes:
                p.join(5)
            # Wait for the pool's manager thread to close its wake-up pipe: left running, it
            # can close the pipe while the interpreter's exit hook writes to it, and a
            # SIGTERM-ed `cell sweep` printed "OSError: [Errno 9] Bad file descriptor" with
            # a traceback (CPython's concurrent.futures.process._python_exit, 3.11).
            if manager is not None:
                manager.join(5)
        else:
            pool.shutdown(wait=True)

    def run(self, chunks: Iterable[Chunk], on_outcomes: Callable[[tuple[Outcome, ...]], None]) -> None:
        """Run every chunk; ``on_outcomes`` is called in this thread as each one finishes."""
        queue: deque[Chunk] = deque()
        source = iter(chunks)
        flying: dict[Future, Chunk] = {}
        restarts = 0
        pool = self._pool or self._start()
        try:
            while True:
                broken = False
                while len(flying) < 2 * self.workers:
                    chunk = queue.popleft() if queue else next(source, None)
                    if chunk is None:
                        break
                    try:
                        flying[pool.submit(run_chunk, chunk, self.render_threads)] = chunk
                    except BrokenProcessPool:  # a worker died since the last results came
                        queue.appendleft(chunk)
                        broken = True
                        break
                if not flying and not broken:
                    break
                if not broken:
                    finished, _ = wait(flying, return_when=FIRST_COMPLETED)
                    for future in finished:
                        chunk = flying.pop(future)
                        try:
                            outcomes = future.result()
                        except BrokenProcessPool:
                            queue.appendleft(chunk)
                            broken = True
                            continue
                        on_outcomes(outcomes)
                if broken:
                    restarts += 1
                    queue.extendleft(reversed(list(flying.values())))
                    flying.clear()
                    self._stop(kill=True)
                    if restarts > MAX_RESTARTS:
                        raise SweepError(f"a worker process died {restarts} times (killed, or out "
                                         "of memory); the finished runs are kept: run the sweep "
                                         "again with --resume")
                    print(f"cell sweep: a worker process died (killed, or out of memory); its "
                          f"unfinished runs are done again (restart {restarts} of {MAX_RESTARTS})",
                          file=sys.stderr, flush=True)
                    pool = self._start()
        except BaseException:
            self._stop(kill=True)
            raise
