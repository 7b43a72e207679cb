"""The backends: the local pool and Ray give the same rows for the same grid; Ctrl-C keeps
every finished row and --resume does only the rest (a crash's half-written row dropped);
a killed worker process costs nothing but its chunk, which is run again."""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import subprocess
import sys
import threading
import time
import types
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from cell.errors import JobError
from cell.sweep import local
from cell.sweep.errors import SweepError
from cell.sweep.plan import plan_sweep
from cell.sweep.raybackend import RayPool
from cell.sweep.runner import SweepOptions, run_plan
from cell.sweep.spec import load_sweep
from cell.sweep.worker import Chunk, Outcome, Task, run_tasks
from tests.sweep import slow_detector
from tests.sweep.helpers import ROOT, TINY, rows_without_timings, write_tiny

# (Ctrl-C, a killed worker: 384 runs whose detector sleeps 0.25 s a frame until the test
# has seen the first rows and interrupted the sweep, so that the sweep cannot finish first,
# however starved of the CPU on a busy machine the test is: at least 48 s of sleep)
LONG = TINY.replace("seeds = [1, 2]", "seeds = {from = 1, to = 64}").replace(
    '"parts.count" = 2', f'"parts.count" = 2\n"vision.detector" = "{slow_detector.NAME}"')


def _slow_until_removed(tmp_path: Path) -> tuple[dict[str, str], Path]:
    """The environment that slows the sweep's detector, and the file to remove to stop it."""
    gate = tmp_path / "slow"
    gate.touch()
    return {slow_detector.SLOW_WHILE: str(gate)}, gate


def test_the_local_pool_and_ray_give_the_same_rows(tmp_path, monkeypatch):
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")  # (tests only: no token written under ~/.ray)
    plan = plan_sweep(load_sweep(write_tiny(tmp_path)))
    local, ray = tmp_path / "local", tmp_path / "ray"
    for out, backend in ((local, "local"), (ray, "ray")):
        out.mkdir()
        result = run_plan(plan, out, SweepOptions(backend=backend, workers=2, progress=False))
        assert (result.ran, result.failed) == (len(plan.runs), 0), backend
    a, b = rows_without_timings(local / "results.csv", plan), rows_without_timings(ray / "results.csv", plan)
    assert len(a) == len(plan.runs)
    # the same runs on one machine; the worker processes may differ in their BLAS threads
    # (Ray sets one), which may move a float's last digits: figures within 1e-9, the rest equal
    assert [[k for k, _ in r] for r in a] == [[k for k, _ in r] for r in b]
    for ra, rb in zip(a, b, strict=True):
        for (key, va), (_, vb) in zip(ra, rb, strict=True):
            if isinstance(va, float) or isinstance(vb, float):
                assert vb == pytest.approx(va, rel=1e-9, abs=1e-12, nan_ok=True), (key, ra)
            else:
                assert va == vb, (key, ra)
    assert (ray / "summary.md").exists() and (ray / "metrics.png").exists()


def _cell(*args: str, env: dict[str, str] | None = None, **kw) -> subprocess.Popen:
    """``cell ARGS`` as a user starts it from a terminal: Ctrl-C (SIGINT) at its default,
    even where the tests themselves run with it ignored (a shell script's ``&`` job)."""
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), **(env or {})}
    return subprocess.Popen([sys.executable, "-m", "cell.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, env=env,
                            preexec_fn=_sigint_default, **kw)


def _sigint_default() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _rows(path: Path) -> list[str]:
    if not path.exists():
        return []
    return [ln.split(",", 1)[0] for ln in path.read_text().splitlines()[1:]]


def _wait_rows(path: Path, n: int, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while len(_rows(path)) < n:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < end, "no rows written"
        time.sleep(0.05)


@dataclasses.dataclass(frozen=True)
class _Stopped:
    """A sweep stopped by a signal: its file, plan, output folder, the gate that slows its
    detector, exit status, stderr and the run ids in its results.csv."""

    sweep: Path
    plan: object
    out: Path
    gate: Path
    status: int
    stderr: str
    done: list[str]


def _stopped_sweep(tmp_path: Path, sig: int) -> _Stopped:
    """A long sweep stopped by ``sig`` once it has two rows (checked: one line, every row
    it finished kept)."""
    sweep, out = write_tiny(tmp_path, LONG), tmp_path / "out"
    plan = plan_sweep(load_sweep(sweep))
    slow, gate = _slow_until_removed(tmp_path)
    proc = _cell("sweep", str(sweep), "--out", str(out), "--workers", "2", env=slow)
    _wait_rows(out / "results.csv", 2, proc)
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=60)
    done = _rows(out / "results.csv")
    assert "Traceback" not in stderr and len(stderr.strip().splitlines()) == 1, stderr
    assert f"{len(done)} of {len(plan.runs)} runs" in stderr and "--resume" in stderr, stderr
    assert 0 < len(done) < len(plan.runs) and len(set(done)) == len(done)
    return _Stopped(sweep, plan, out, gate, proc.returncode, stderr, done)


def test_ctrl_c_keeps_the_finished_rows_and_resume_does_the_rest(tmp_path):
    stop = _stopped_sweep(tmp_path, signal.SIGINT)
    assert stop.status == 130 and stop.stderr.startswith("cell sweep: interrupted: "), stop.stderr
    sweep, plan, out, gate, done = stop.sweep, stop.plan, stop.out, stop.gate, stop.done
    todo = next(r for r in plan.runs if r.run_id not in done)
    with open(out / "results.csv", "ab") as f:  # as if the machine died mid-row
        f.write(f"{todo.run_id},detect,{todo.scenario.seed},fr".encode())
    gate.unlink()
    proc = _cell("sweep", str(sweep), "--out", str(out), "--workers", "2", "--resume")
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    assert f"{len(done)} resumed, {len(plan.runs) - len(done)} run now" in stdout
    assert "half-written" in stdout
    final = _rows(out / "results.csv")
    assert sorted(final) == sorted(r.run_id for r in plan.runs)
    assert final[: len(done)] == done  # the finished rows were kept as they were


def test_sigterm_keeps_the_finished_rows_and_says_terminated(tmp_path):
    stop = _stopped_sweep(tmp_path, signal.SIGTERM)
    assert stop.status == 143 and stop.stderr.startswith("cell sweep: terminated: "), stop.stderr


def test_a_stopped_pool_leaves_no_thread_behind():
    """Stopping the pool mid-chunk (Ctrl-C, SIGTERM) waits for its manager thread: left
    running, it raced the interpreter's exit hook, and a SIGTERM-ed sweep now and then
    printed a traceback (EBADF) under its one line."""
    before = set(threading.enumerate())
    pool = local.LocalPool(1)
    pool.start()
    pool._pool.submit(time.sleep, 30)
    pool._stop(kill=True)
    left = [t.name for t in set(threading.enumerate()) - before]
    assert left == [], left


def _children(pid: int) -> list[int]:
    """The child processes of ``pid`` (from /proc: each process's parent id)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _worker_pids(pid: int) -> list[int]:
    out = []
    for child in _children(pid):
        try:
            cmd = Path(f"/proc/{child}/cmdline").read_bytes()
        except OSError:
            continue
        if b"spawn_main" in cmd and b"resource_tracker" not in cmd:
            out.append(child)
    return out


def test_a_killed_worker_loses_nothing(tmp_path):
    sweep, out = write_tiny(tmp_path, LONG), tmp_path / "out"
    plan = plan_sweep(load_sweep(sweep))
    slow, gate = _slow_until_removed(tmp_path)
    proc = _cell("sweep", str(sweep), "--out", str(out), "--workers", "2", env=slow)
    _wait_rows(out / "results.csv", 2, proc)
    workers = _worker_pids(proc.pid)
    assert workers, "no worker process found"
    os.kill(workers[0], signal.SIGKILL)
    gate.unlink()
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    assert "a worker process died" in stderr and "Traceback" not in stderr, (stdout, stderr)
    rows = _rows(out / "results.csv")
    assert sorted(rows) == sorted(r.run_id for r in plan.runs)


def test_workers_end_with_a_killed_sweep(tmp_path):
    """kill -9 of the sweep (the out-of-memory killer) left its workers waiting forever,
    holding its stdout open (``cell sweep ... | tee log`` did not end): they end within
    seconds now."""
    sweep, out = write_tiny(tmp_path, LONG), tmp_path / "out"
    slow, gate = _slow_until_removed(tmp_path)
    proc = _cell("sweep", str(sweep), "--out", str(out), "--workers", "2", env=slow)
    _wait_rows(out / "results.csv", 2, proc)
    workers = _worker_pids(proc.pid)
    assert workers, "no worker process found"
    proc.kill()
    proc.communicate(timeout=30)  # (returns once no process holds its pipes)
    gate.unlink()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(_running(w) for w in workers):
        time.sleep(0.2)
    assert not any(_running(w) for w in workers)


def _running(pid: int) -> bool:
    """Whether ``pid`` is a live process (not gone, not a zombie waiting for init)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _job(fail: dict[str, Exception]):
    """A job whose run ``task.scenario`` (a name here) raises ``fail[name]``, if any."""

    def measure(scene, scenario, settings):
        if scenario in fail:
            raise fail[scenario]
        return {"score": 1.0}

    return types.SimpleNamespace(METRICS=("score",), TIMINGS=(), scene_key=lambda sc, st: None,
                                 prepare=None, measure=measure)


def test_a_run_that_fails_on_purpose_is_a_row_with_its_message_escaped(monkeypatch):
    job = _job({"bad": JobError("detector 'x:Y' raised: boom \x1b[31mred\nline\x00")})
    monkeypatch.setattr("cell.sweep.jobs.job_module", lambda name: job)
    chunk = Chunk("fake", (Task("r1", "bad", None), Task("r2", "good", None)))
    bad, good = run_tasks(chunk)
    assert bad.figures == {} and bad.error == "detector 'x:Y' raised: boom \\x1b[31mred line\\x00"
    assert bad.error.isprintable() and good == Outcome("r2", {"score": 1.0}, None)


def test_a_bug_in_a_run_stops_the_sweep_naming_the_run(monkeypatch):
    job = _job({"bug": ZeroDivisionError("division by zero")})
    monkeypatch.setattr("cell.sweep.jobs.job_module", lambda name: job)
    with pytest.raises(ZeroDivisionError) as info:
        run_tasks(Chunk("fake", (Task("r1", "good", None), Task("r2", "bug", None))))
    assert any("run r2 (job 'fake')" in note and "--resume" in note for note in info.value.__notes__)


def test_ray_leaves_the_callers_process_as_it_was(monkeypatch):
    # (after a Ray sweep PYTHONBREAKPOINT pointed at Ray's debugger, so breakpoint() only
    # logged an error; Ray's excepthook and RAY_* variables stayed)
    from cell.sweep.raybackend import RayPool

    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    env, hook = dict(os.environ), sys.excepthook
    term = signal.getsignal(signal.SIGTERM)
    with RayPool(1):
        assert signal.getsignal(signal.SIGTERM) is term  # (the command's own, meanwhile too)
    assert dict(os.environ) == env and sys.excepthook is hook


class _FakeExecutor:
    """Stands in for the process pool: each submit is answered at once, by ``answer``."""

    def __init__(self, answer, log):
        self.answer, self.log = answer, log

    def submit(self, fn, chunk, threads):
        self.log.append(("submit", chunk.job))
        future = Future()
        result = self.answer(chunk)
        if isinstance(result, BaseException):
            future.set_exception(result)
        else:
            future.set_result(result)
        return future

    def shutdown(self, wait=True, cancel_futures=False):
        self.log.append(("shutdown", wait))


def _chunks(n):
    return [Chunk(f"c{i}", (Task(f"r{i}", None, None),)) for i in range(n)]


def _pool(monkeypatch, answer, workers=3):
    log = []
    pool = local.LocalPool(workers)

    def start():
        log.append(("start",))
        pool._pool = _FakeExecutor(answer, log)
        return pool._pool

    monkeypatch.setattr(pool, "_start", start)
    return pool, log


def test_a_pool_that_keeps_breaking_is_restarted_max_restarts_times_then_stops(monkeypatch, capsys):
    pool, log = _pool(monkeypatch, lambda chunk: BrokenProcessPool("died"))
    with pytest.raises(SweepError, match=f"died {local.MAX_RESTARTS + 1} times"):
        pool.run(_chunks(2), lambda outcomes: None)
    assert sum(e == ("start",) for e in log) == 1 + local.MAX_RESTARTS == 4
    err = capsys.readouterr().err
    assert err.count("a worker process died") == local.MAX_RESTARTS
    assert f"restart {local.MAX_RESTARTS} of {local.MAX_RESTARTS}" in err


def test_two_chunks_per_worker_are_in_flight_and_every_chunk_comes_back(monkeypatch):
    pool, log = _pool(monkeypatch, lambda chunk: (Outcome(chunk.tasks[0].run_id, {}, None),))
    seen = []
    pool.run(_chunks(10), lambda outcomes: (log.append(("result",)), seen.extend(outcomes)))
    assert sorted(o.run_id for o in seen) == sorted(f"r{i}" for i in range(10))
    first = log.index(("result",))
    assert sum(e[0] == "submit" for e in log[:first]) == 2 * pool.workers


def test_chunks_hold_every_run_once_at_most_chunk_runs_each_sharing_a_scene(tmp_path):
    import tomllib

    from cell.sweep.jobs import job_module
    from cell.sweep.plan import plan_sweep
    from cell.sweep.runner import make_chunks
    from cell.sweep.spec import sweep_from_dict
    from tests.sweep.helpers import TINY

    plan = plan_sweep(sweep_from_dict(tomllib.loads(TINY), source=str(tmp_path / "s.toml"),
                                      folder=tmp_path))
    by_id = {r.run_id: r for r in plan.runs}
    for size in (1, 2, 24):
        chunks = list(make_chunks(list(plan.runs), chunk_runs=size))
        ids = [t.run_id for c in chunks for t in c.tasks]
        assert sorted(ids) == sorted(by_id) and max(len(c.tasks) for c in chunks) <= size
        for c in chunks:  # one scene per chunk
            keys = {job_module(c.job).scene_key(by_id[t.run_id].scenario, by_id[t.run_id].settings)
                    for t in c.tasks}
            assert len(keys) == 1
    assert len(list(make_chunks(list(plan.runs), chunk_runs=24))) == 4  # 2 lights x 2 seeds


def _fake_job(measure, prepare=lambda scenario, settings: object()):
    return SimpleNamespace(METRICS=("a", "b", "c"), TIMINGS=(), measure=measure, prepare=prepare,
                           scene_key=lambda scenario, settings: scenario)


def test_a_figure_that_is_not_finite_becomes_none_and_numpy_numbers_plain(monkeypatch):
    job = _fake_job(lambda scene, scenario, settings: {"a": math.inf, "b": np.float64("nan"),
                                                       "c": np.int64(3)})
    monkeypatch.setattr("cell.sweep.jobs.job_module", lambda name: job)
    (out,) = run_tasks(Chunk("fake", (Task("r1", ("inf", id(job)), None),)))
    assert out == Outcome("r1", {"a": None, "b": None, "c": 3}, None)
    assert type(out.figures["c"]) is int


def test_a_figure_the_job_does_not_declare_stops_the_sweep(monkeypatch):
    job = _fake_job(lambda scene, scenario, settings: {"a": 1.0, "typo": 2.0})
    monkeypatch.setattr("cell.sweep.jobs.job_module", lambda name: job)
    with pytest.raises(TypeError, match="does not declare: \\['typo'\\]"):
        run_tasks(Chunk("fake", (Task("r1", ("typo", id(job)), None),)))


def test_runs_sharing_a_scene_key_render_it_once(monkeypatch):
    prepared = []
    job = _fake_job(lambda scene, scenario, settings: {"a": 1.0},
                    prepare=lambda scenario, settings: prepared.append(scenario) or object())
    monkeypatch.setattr("cell.sweep.jobs.job_module", lambda name: job)
    key = ("shared", id(job))
    run_tasks(Chunk("fake", tuple(Task(f"r{i}", key, None) for i in range(3))))
    assert prepared == [key]


class _FakeRay:
    """Stands in for ``ray``: each task's result is ``answer(chunk)``, raised if an exception."""

    class exceptions:  # noqa: N801 (as ray spells it)
        class RayError(Exception):
            pass

        class RayTaskError(RayError):
            def __init__(self, cause):
                super().__init__(f"remote: {cause!r}")
                self.cause = cause

    def __init__(self, answer):
        self.answer, self.cancelled = answer, []

    def wait(self, refs, num_returns=1):
        return refs[:num_returns], refs[num_returns:]

    def get(self, ref):
        result = self.answer(ref)
        if isinstance(result, BaseException):
            raise result
        return result

    def cancel(self, ref, force=False):
        self.cancelled.append(ref)


def _ray_pool(answer):
    pool = RayPool(1)
    fake = _FakeRay(answer)
    pool._ray, pool._task = fake, SimpleNamespace(remote=lambda chunk, threads: chunk)
    return pool, fake


def test_a_bug_in_a_ray_task_is_raised_as_the_runs_own_error_and_the_rest_cancelled():
    bug = ZeroDivisionError("division by zero")
    bug.add_note("cell sweep: run r0 (job 'fake') stopped the sweep")
    chunks = [Chunk("fake", (Task(f"r{i}", None, None),)) for i in range(3)]
    pool, fake = _ray_pool(lambda chunk: _FakeRay.exceptions.RayTaskError(bug)
                           if chunk is chunks[0] else (Outcome(chunk.tasks[0].run_id, {}, None),))
    with pytest.raises(ZeroDivisionError) as info:
        pool.run(chunks, lambda outcomes: None)
    assert info.value is bug and "run r0" in info.value.__notes__[0]
    assert fake.cancelled == [chunks[1]]  # the other chunk in flight (two per worker)


def test_ray_leaves_a_fresh_process_as_it_was():
    # in-process, the test above is masked once any earlier test has used Ray: the first
    # use is what sets PYTHONBREAKPOINT and RAY_* (a fresh process sees it every time)
    import os
    import subprocess
    import sys
    from pathlib import Path

    code = ("import os\nfrom cell.sweep.raybackend import RayPool\nenv = dict(os.environ)\n"
            "with RayPool(1):\n    pass\nprint(sorted(set(os.environ) ^ set(env)))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       cwd=Path(__file__).parent.parent.parent,
                       env={**os.environ, "RAY_AUTH_MODE": "disabled"})
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.splitlines()[-1] == "[]", r.stdout
