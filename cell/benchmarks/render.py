"""``cell bench render``: rendering and physics speed of the cell.

Prints, for each camera, milliseconds per frame for RGB (under an unshadowed preset and
under ``raking``, the one preset with shadows), depth and segmentation, and the cost of
the sensor model as a ratio to the raw render; then physics steps per second with the
arm and 10 parts on the belt and the real-time factor (simulated / wall seconds).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from cell.scenario import scenario_from_dict
from cell.sim.world import World

__all__ = ["main", "run"]

RGB_TARGET_MS = 25.0  # the budget for one 640x480 RGB frame on a 2-core CPU


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
            out["sensor_overhead_ratio"] = out["rgb_front_ms"] / out["rgb_raw_front_ms"]
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
            "steps_per_s": steps / wall, "real_time_factor": (world.time - sim0) / wall,
        },
    }


def _print(result: dict) -> None:
    w, h = result["image"]
    print(f"render, {w}x{h}, median ms per frame (RGB includes the sensor model)")
    print(f"{'camera':<10}{'rgb front':>10}{'rgb raking':>11}{'raw front':>10}{'depth':>8}{'seg':>8}"
          f"{'sensor x':>10}{'worst/25ms':>11}")
    for cam, r in result["cameras"].items():
        print(f"{cam:<10}{r['rgb_front_ms']:>10.1f}{r['rgb_raking_ms']:>11.1f}{r['rgb_raw_front_ms']:>10.1f}"
              f"{r['depth_ms']:>8.1f}{r['seg_ms']:>8.1f}{r['sensor_overhead_ratio']:>10.2f}"
              f"{r['rgb_worst_vs_target_ratio']:>11.2f}")
    p = result["physics"]
    print(f"physics: {p['steps_per_s']:.0f} steps/s with the arm and 10 parts "
          f"({p['dofs']} dofs), real-time factor {p['real_time_factor']:.1f}x")


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="cell bench render", description=__doc__.splitlines()[0])
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--repeats", type=int, default=30, help="frames per measurement")
    p.add_argument("--quick", action="store_true", help="few repeats and steps (smoke test)")
    args = p.parse_args(argv)
    result = run(repeats=3, steps=200) if args.quick else run(repeats=args.repeats)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        _print(result)
    return 0
