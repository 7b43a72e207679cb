"""``cell bench render``: rendering and physics speed of the cell.

Prints, for each camera, milliseconds per frame for RGB (under an unshadowed preset and
under ``raking``, the one preset with shadows), depth and segmentation, and the cost of
the sensor model as a ratio to the raw render; then physics steps per second with the
arm and 10 parts on the belt and the real-time factor (simulated / wall seconds).
A ratio whose denominator measured zero is ``None`` (``null`` in JSON, ``-`` in the table).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from cell.benchmarks import fmt, int_in
from cell.scenario import scenario_from_dict

__all__ = ["MAX_REPEATS", "main", "parser", "run"]

RGB_TARGET_MS = 25.0  # the budget for one 640x480 RGB frame on a 2-core CPU
MAX_REPEATS = 10_000


def _ratio(a: float, b: float) -> float | None:
    return a / b if b > 0 else None


def _ms(fn, repeats: int) -> float:
    fn()  # warm up (first frame uploads textures)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000.0 * float(np.median(times))


def run(*, repeats: int = 30, steps: int = 5000, width: int = 640, height: int = 480) -> dict:
    """Measure and return the figures as a dict (see the module docstring)."""
    from cell.sim.world import World

    if not 1 <= repeats <= MAX_REPEATS:
        raise ValueError(f"repeats: must be 1 to {MAX_REPEATS}, got {repeats}")
    if steps < 1:
        raise ValueError(f"steps: must be at least 1, got {steps}")
    scenario = scenario_from_dict({"seed": 0, "parts": {"count": 10},
                                   "camera": {"width": width, "height": height}})
    world = World.build(scenario, arm=True)
    try:
        world.run_until_part_at_pick(timeout=30)  # parts on the belt, one at the barrier
        cameras = {}
        for cam in ("overhead", "wrist"):
            rig = world.rig(cam)
            out = {}
            for preset in ("front", "raking"):
                world.set_lighting(preset)
                out[f"rgb_raw_{preset}_ms"] = _ms(lambda r=rig: r.render_rgb(world.data), repeats)
                out[f"rgb_{preset}_ms"] = _ms(lambda c=cam: world.render(c, depth=False, seg=False),
                                              repeats)
            world.set_lighting("front")
            out["depth_ms"] = _ms(lambda r=rig: r.render_depth(world.data), repeats)
            out["seg_ms"] = _ms(lambda r=rig: r.render_seg(world.data), repeats)
            out["sensor_overhead_ratio"] = _ratio(out["rgb_front_ms"], out["rgb_raw_front_ms"])
            out["rgb_worst_vs_target_ratio"] = max(out["rgb_front_ms"], out["rgb_raking_ms"]) / RGB_TARGET_MS
            cameras[cam] = out
        world.conveyor.mode = "continuous"  # keep parts moving: contacts change every step
        t0 = time.perf_counter()
        sim0 = world.time
        world.step(steps)
        wall = time.perf_counter() - t0
    finally:
        world.close()
    return {
        "image": [width, height],
        "cameras": cameras,
        "physics": {
            "bodies": int(world.model.nbody), "dofs": int(world.model.nv),
            "steps_per_s": _ratio(steps, wall), "real_time_factor": _ratio(world.time - sim0, wall),
        },
    }


def _print(result: dict) -> None:
    w, h = result["image"]
    print(f"render, {w}x{h}, median ms per frame (RGB includes the sensor model)")
    print(f"{'camera':<10}{'rgb front':>10}{'rgb raking':>11}{'raw front':>10}{'depth':>8}{'seg':>8}"
          f"{'sensor x':>10}{'worst/25ms':>11}")
    for cam, r in result["cameras"].items():
        print(f"{cam:<10}{r['rgb_front_ms']:>10.1f}{r['rgb_raking_ms']:>11.1f}{r['rgb_raw_front_ms']:>10.1f}"
              f"{r['depth_ms']:>8.1f}{r['seg_ms']:>8.1f}{fmt(r['sensor_overhead_ratio'], '>10.2f')}"
              f"{r['rgb_worst_vs_target_ratio']:>11.2f}")
    p = result["physics"]
    print(f"physics: {fmt(p['steps_per_s'], '.0f')} steps/s with the arm and 10 parts "
          f"({p['dofs']} dofs), real-time factor {fmt(p['real_time_factor'], '.1f')}x")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cell bench render",
                                description="rendering and physics speed of the cell")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--repeats", type=int_in(1, MAX_REPEATS), default=None, metavar="N",
                   help=f"frames per measurement, 1 to {MAX_REPEATS} (default 30; 3 with --quick)")
    p.add_argument("--quick", action="store_true",
                   help="3 repeats and 200 physics steps (smoke test; --repeats overrides)")
    return p


def main(argv: list[str]) -> int:
    args = parser().parse_args(argv)
    repeats = args.repeats if args.repeats is not None else (3 if args.quick else 30)
    result = run(repeats=repeats, steps=200) if args.quick else run(repeats=repeats)
    if args.json:
        print(json.dumps(result, indent=2, allow_nan=False))
    else:
        _print(result)
    return 0
