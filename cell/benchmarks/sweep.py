"""``cell bench sweep``: sweep throughput with 1 and 2 local workers and with Ray.

One fixed grid (the detect job: 8 lighting presets x 2 segmentations x ``--seeds`` seeds,
6 parts per scene; 16 runs per seed, two runs per rendered scene) runs into a temporary
folder, results.csv written row by row as in a real sweep, on three set-ups: the local
pool with 1 worker, with 2 workers, and Ray on this machine with 2 CPUs. Each set-up is
started and warmed first (one small chunk per worker: the imports and the first GL
context), then the grid is timed: ``runs_per_min`` is the grid's runs over that time (a
long sweep's rate); ``startup_s`` is the start and warm-up, and ``runs_per_min_total``
counts it in. The set-ups take turns ``--repeats`` times and each keeps its best pass (a
shared machine's other work only slows a pass down). The rows of every set-up are
compared with the first's, wall-time columns left out (``same_rows``). Ratios:
2 workers over 1 (must reach 1.7, aim 1.9) and Ray over 2 local workers (must be within
15 %, aim 10 %).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from cell.benchmarks import fmt, int_in
from cell.errors import BenchError
from cell.options import Parser

__all__ = ["GRID", "main", "parser", "run"]

GRID = """
[sweep]
name = "bench"
title = "cell bench sweep"
job = "detect"
seeds = {{from = 1, to = {seeds}}}

[scenario]
"parts.count" = 6

[grid]
lighting = ["front", "back", "raking", "coaxial", "dim", "glare", "warm", "cool"]
"vision.segmentation" = ["belt", "otsu"]
"""
_SETUPS = (("local_1", "local", 1), ("local_2", "local", 2), ("ray_2", "ray", 2))
_REQUIRED = {"local_2_over_local_1": 1.7, "ray_within": 0.15}
_AIM = {"local_2_over_local_1": 1.9, "ray_within": 0.10}


def _plan(seeds: int):
    import tomllib

    from cell.sweep.plan import plan_sweep
    from cell.sweep.spec import sweep_from_dict

    return plan_sweep(sweep_from_dict(tomllib.loads(GRID.format(seeds=seeds)), source="bench grid",
                                      folder=Path(".")))


def _warm_chunks(workers: int):
    from cell.scenario import scenario_from_dict
    from cell.sweep.jobs import detect
    from cell.sweep.worker import Chunk, Task

    return [Chunk("detect", (Task(f"warm{i}", scenario_from_dict(
        {"seed": 10_000 + i, "parts": {"count": 1}}), detect.Settings()),)) for i in range(workers)]


def _rows(path: Path, drop: tuple[str, ...]) -> list[tuple]:
    from cell.sweep.results import read_rows

    _, rows = read_rows(path)
    return sorted(tuple((k, v) for k, v in r.items() if k not in drop) for r in rows)


def _one(plan, kind: str, workers: int, out: Path) -> dict:
    from cell.sweep.runner import SweepOptions, make_backend, run_plan

    options = SweepOptions(backend=kind, workers=workers, progress=False, report=False)
    t0 = time.perf_counter()
    backend = make_backend(options)
    try:
        backend.start()
        backend.run(_warm_chunks(workers), lambda outcomes: None)
        ready = time.perf_counter()
        result = run_plan(plan, out, options, backend=backend)
        end = time.perf_counter()
    finally:
        backend.close()
    if result.ran != len(plan.runs) or result.failed:
        raise BenchError(f"{kind} x{workers}: {result.ran} runs, {result.failed} failed")
    return {"startup_s": ready - t0, "sweep_s": end - ready, "total_s": end - t0}


def run(*, seeds: int = 6, repeats: int = 2, ray: bool = True) -> dict:
    """Time the bench grid on each set-up (see the module docstring); the report."""
    plan = _plan(seeds)
    n = len(plan.runs)
    setups = [s for s in _SETUPS if ray or s[1] != "ray"]
    passes: dict[str, list[dict]] = {name: [] for name, _, _ in setups}
    drop = plan.columns.timings
    same = True
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="cell-bench-sweep-") as tmp:
        reference = None
        for r in range(repeats):
            for name, kind, workers in setups:
                out = Path(tmp) / f"{name}-{r}"
                out.mkdir()
                passes[name].append(_one(plan, kind, workers, out))
                rows = _rows(out / "results.csv", drop)
                reference = rows if reference is None else reference
                same = same and rows == reference
    report: dict = {"grid": {"job": "detect", "runs": n, "seeds": seeds,
                             "scenes": len({(r.scenario.seed, r.scenario.lighting) for r in plan.runs})},
                    "repeats": repeats, "load_average_before": load, "setups": {}}
    for name, _, workers in setups:
        best = min(passes[name], key=lambda p: p["sweep_s"])
        report["setups"][name] = {
            "workers": workers, "runs_per_min": 60.0 * n / best["sweep_s"],
            "runs_per_min_total": 60.0 * n / best["total_s"], "startup_s": best["startup_s"],
            "sweep_s": [p["sweep_s"] for p in passes[name]]}
    s = report["setups"]
    ratio = s["local_2"]["runs_per_min"] / s["local_1"]["runs_per_min"]
    ray_ratio = s["ray_2"]["runs_per_min"] / s["local_2"]["runs_per_min"] if "ray_2" in s else None
    report["ratios"] = {
        "local_2_over_local_1": ratio,
        "ray_over_local_2": ray_ratio,
        "local_2_over_local_1_total": s["local_2"]["runs_per_min_total"] / s["local_1"]["runs_per_min_total"],
        "ray_over_local_2_total": (s["ray_2"]["runs_per_min_total"] / s["local_2"]["runs_per_min_total"]
                                   if "ray_2" in s else None)}
    report["same_rows"] = same
    report["required"], report["aim"] = _REQUIRED, _AIM
    report["meets_required"] = (ratio >= _REQUIRED["local_2_over_local_1"] and same
                                and (ray_ratio is None or ray_ratio >= 1 - _REQUIRED["ray_within"]))
    return report


def _print(report: dict) -> None:
    g = report["grid"]
    print(f"cell bench sweep: detect job, {g['runs']} runs ({g['scenes']} scenes, {g['seeds']} seeds), "
          f"best of {report['repeats']} passes; load average before {report['load_average_before']:.2f}")
    print(f"{'set-up':<8} {'workers':>7} {'runs/min':>9} {'startup s':>9} {'runs/min total':>14}  passes (s)")
    for name, s in report["setups"].items():
        passes = " ".join(f"{t:.1f}" for t in s["sweep_s"])
        print(f"{name:<8} {s['workers']:>7} {s['runs_per_min']:>9.1f} {s['startup_s']:>9.2f} "
              f"{s['runs_per_min_total']:>14.1f}  {passes}")
    r = report["ratios"]
    print(f"2 workers / 1: {r['local_2_over_local_1']:.2f}x (total {r['local_2_over_local_1_total']:.2f}x); "
          f"Ray / 2 local workers: {fmt(r['ray_over_local_2'], '.2f')} (total "
          f"{fmt(r['ray_over_local_2_total'], '.2f')}); same rows on every set-up: {report['same_rows']}")
    print(f"required: 2 workers >= {_REQUIRED['local_2_over_local_1']}x one, Ray within "
          f"{100 * _REQUIRED['ray_within']:.0f} % of the local pool (aim {_AIM['local_2_over_local_1']}x, "
          f"{100 * _AIM['ray_within']:.0f} %): {'met' if report['meets_required'] else 'NOT met'}")


def parser() -> argparse.ArgumentParser:
    p = Parser(
        prog="cell bench sweep",
        description="sweep throughput (runs per minute) with 1 and 2 local workers and with Ray")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quick", action="store_true", help="2 seeds, one pass (smoke test)")
    p.add_argument("--seeds", type=int_in(1, 1000), default=None, metavar="N",
                   help="seeds of the grid, 1 to 1000 (16 runs each; default 6)")
    p.add_argument("--repeats", type=int_in(1, 100), default=None, metavar="N",
                   help="passes per set-up, 1 to 100, the best kept (default 2)")
    p.add_argument("--no-ray", action="store_true", help="leave the Ray set-up out")
    return p


def main(argv: list[str]) -> int:
    args = parser().parse_args(argv)
    seeds = args.seeds if args.seeds is not None else (2 if args.quick else 6)
    repeats = args.repeats if args.repeats is not None else (1 if args.quick else 2)
    report = run(seeds=seeds, repeats=repeats, ray=not args.no_ray)
    if args.json:
        print(json.dumps(report, indent=2, allow_nan=False))
    else:
        _print(report)
    return 0
