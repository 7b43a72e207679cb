"""``cell bench pick [--json] [--quick] [--poses N] [--seed S]``: the robot alone.

For each part kind, ``N`` (default 20) random poses in the pick zone, given from the
simulator's ground truth (this isolates the robot from vision): the part is put at
rest on the stopped belt, the pick-and-place skill takes it to its class's bin, and
the part's final ground-truth position scores the pick (success = it lies inside the
right bin). Reported per kind and overall:

- success rate;
- mean cycle time (simulated s, from HOME over the part, to the bin and back to HOME);
- ratio of the cycle time to the time-optimal bound: the sum of the minimum times of
  the same joint segments (rest-to-rest straight joint lines) under the same speed and
  acceleration limits (the ratio is measured per cycle, in one run);
- cycles per simulated minute;
- IK wall time per solve (ms): mean and 95th percentile, and iterations per solve;
- the peak torque of each joint over its UR5e rating (servos plus feed-forward), and
  the largest error between a joint and its reference during the motions (mrad).

A figure with no samples (no cycle finished) is ``None``: ``null`` in JSON, ``-`` in the
table; never NaN.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from cell.benchmarks import float_in, fmt, int_in
from cell.catalogue import KINDS
from cell.errors import BenchError, CellError
from cell.options import Parser
from cell.scenario import scenario_from_dict

__all__ = ["MAX_POSES", "main", "parser", "run_kind"]

MAX_POSES = 199  # poses per kind: the scenario holds poses + 1 parts, at most 200

_X_RANGE = 0.04  # pick-zone poses: x within +-this of PICK_ZONE (m)
_Y_RANGE = 0.05  # and y within +-this of the belt's centre line (m)


def run_kind(kind: str, poses: int, seed: int, *, noise_mm: float = 0.0,
             noise_deg: float = 0.0) -> dict:
    """Run ``poses`` pick-and-place cycles of ``kind``; returns the figures as a dict.

    ``noise_mm`` / ``noise_deg``: standard deviation of Gaussian errors added to the
    ground-truth position (each axis, mm) and yaw (deg) given to the robot, to see how
    much pose error a vision stack may leave. Figures with no samples are ``None``."""
    from cell.robot.pick import PartTarget, PickPlace
    from cell.sim import World, layout
    from cell.sim.arm import EFFORT, JOINT_NAMES

    if kind not in KINDS:
        raise BenchError(f"kind: unknown {kind!r}; valid: {', '.join(KINDS)}")
    if not 1 <= poses <= MAX_POSES:
        raise BenchError(f"poses: must be 1 to {MAX_POSES}, got {poses}")
    if not (np.isfinite(noise_mm) and np.isfinite(noise_deg) and noise_mm >= 0 and noise_deg >= 0):
        raise BenchError(f"noise: must be finite and >= 0, got {noise_mm} mm, {noise_deg} deg")

    scenario = scenario_from_dict({
        "seed": seed, "parts": {"count": poses + 1, "kinds": [kind]},
        "conveyor": {"speed": 0.0},
    })
    world = World.build(scenario)
    rng = np.random.default_rng([seed, list(KINDS).index(kind)])
    noise_rng = np.random.default_rng([seed, list(KINDS).index(kind), 1])  # same poses
    effort = np.array(EFFORT)
    peak = np.zeros(6)
    dofs = [world.model.joint(f"arm/{n}").dofadr[0] for n in JOINT_NAMES]

    def step(n: int) -> None:  # world.step, also recording the peak joint torques
        nonlocal peak
        for _ in range(n):
            world.step(1)
            peak = np.maximum(peak, np.abs(world.data.qfrc_actuator[dofs]))

    skill = PickPlace(world.model, world.data, step, scenario.robot)
    world.step(50)  # with the belt stopped the first (upstream) spawn stays at SPAWN_X
    cycles, ratios, ik_ms, ik_its, errors, ok = [], [], [], [], [], 0
    for _ in range(poses):
        x = layout.PICK_ZONE[0] + rng.uniform(-_X_RANGE, _X_RANGE)
        y = layout.CONVEYOR_Y + rng.uniform(-_Y_RANGE, _Y_RANGE)
        part = world.place_next_part(x, y, rng.uniform(0.0, 2 * np.pi))
        world.step(50)  # comes to rest
        pos, _ = world.part_pose(part.id)  # GROUND TRUTH: the benchmark's input
        err = noise_rng.normal(0.0, 1.0, 3) * [noise_mm / 1000, noise_mm / 1000, np.deg2rad(noise_deg)]
        target = PartTarget(part.kind, float(pos[0] + err[0]), float(pos[1] + err[1]),
                            world.part_yaw(part.id) + float(err[2]), part.material)
        try:
            result = skill.run(target)
        except CellError as exc:
            errors.append(str(exc))
        else:
            cycles.append(result.cycle_time)
            ratios.append(result.cycle_time / result.bound_time)
            ik_ms += [1000 * t for t in result.ik_times]
            ik_its += list(result.ik_iterations)
        world.step(150)  # let the part come to rest in the bin
        ok += world.place_of(part.id) == part.material
    world.close()
    mean_cycle = _mean(cycles)
    return {
        "poses": poses,
        "success_rate": ok / poses,
        "mean_cycle_s": mean_cycle,
        "cycles_per_min": 60.0 / mean_cycle if mean_cycle else None,
        "ratio_to_optimal": _mean(ratios),
        "ratio_to_optimal_max": float(np.max(ratios)) if ratios else None,
        "ik_ms_mean": _mean(ik_ms),
        "ik_ms_p95": float(np.percentile(ik_ms, 95)) if ik_ms else None,
        "ik_iterations_mean": _mean(ik_its),
        "max_tracking_error_mrad": 1000 * skill.driver.max_tracking_error,
        "peak_torque_over_effort": [round(float(v), 3) for v in peak / effort],
        "errors": errors,
    }


def _mean(values: list[float]) -> float | None:
    """The mean of the figures that were measured (``None`` ones left out); ``None`` if none."""
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def parser() -> argparse.ArgumentParser:
    ap = Parser(
        prog="cell bench pick",
        description="the robot alone: pick-and-place cycles from ground-truth poses, per part kind")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--quick", action="store_true",
                    help="2 poses per kind (smoke test; --poses overrides)")
    ap.add_argument("--poses", type=int_in(1, MAX_POSES), default=None, metavar="N",
                    help=f"poses per kind, 1 to {MAX_POSES} (default 20)")
    ap.add_argument("--seed", type=int_in(0, 2**63 - 1), default=0, metavar="S",
                    help="seed of the poses, 0 to 2**63-1 (default 0)")
    ap.add_argument("--pose-noise-mm", type=float_in(0.0, 100.0), default=0.0, metavar="MM",
                    help="std of the position error given to the robot, per axis, 0 to 100 mm "
                    "(default 0)")
    ap.add_argument("--yaw-noise-deg", type=float_in(0.0, 180.0), default=0.0, metavar="DEG",
                    help="std of the yaw error given to the robot, 0 to 180 deg (default 0)")
    ap.add_argument("--kinds", nargs="*", default=None, choices=list(KINDS), metavar="KIND",
                    help=f"part kinds to pick, one or more of: {', '.join(KINDS)} (default: all)")
    return ap


def main(argv: list[str]) -> int:
    ap = parser()
    args = ap.parse_args(argv)
    if args.kinds == []:
        ap.error(f"argument --kinds: give one or more of: {', '.join(KINDS)}")
    kinds = list(dict.fromkeys(args.kinds)) if args.kinds else list(KINDS)
    poses = args.poses if args.poses is not None else (2 if args.quick else 20)
    t0 = time.perf_counter()
    per_kind = {k: run_kind(k, poses, args.seed, noise_mm=args.pose_noise_mm,
                            noise_deg=args.yaw_noise_deg) for k in kinds}
    rows = list(per_kind.values())
    n = sum(r["poses"] for r in rows)
    mean_cycle = _mean([r["mean_cycle_s"] for r in rows])
    overall = {
        "poses": n,
        "success_rate": sum(r["success_rate"] * r["poses"] for r in rows) / n,
        "mean_cycle_s": mean_cycle,
        "cycles_per_min": 60.0 / mean_cycle if mean_cycle else None,
        "ratio_to_optimal": _mean([r["ratio_to_optimal"] for r in rows]),
        "ik_ms_mean": _mean([r["ik_ms_mean"] for r in rows]),
        "wall_s": time.perf_counter() - t0,
    }
    if args.json:
        print(json.dumps({"benchmark": "pick", "seed": args.seed,
                          "pose_noise_mm": args.pose_noise_mm,
                          "yaw_noise_deg": args.yaw_noise_deg, "kinds": per_kind,
                          "overall": overall}, indent=2, allow_nan=False))
        return 0
    noise = (f", pose error std {args.pose_noise_mm} mm / {args.yaw_noise_deg} deg"
             if args.pose_noise_mm or args.yaw_noise_deg else "")
    print(f"pick benchmark: {poses} ground-truth poses per kind, seed {args.seed}{noise}")
    print(f"{'kind':<11} {'success':>8} {'cycle s':>8} {'cyc/min':>8} {'ratio':>6} "
          f"{'ratio max':>9} {'IK ms':>6} {'IK p95':>7} {'IK it':>6}")
    for k, r in per_kind.items():
        print(f"{k:<11} {100 * r['success_rate']:>7.1f}% {fmt(r['mean_cycle_s'], '>8.3f')} "
              f"{fmt(r['cycles_per_min'], '>8.1f')} {fmt(r['ratio_to_optimal'], '>6.3f')} "
              f"{fmt(r['ratio_to_optimal_max'], '>9.3f')} {fmt(r['ik_ms_mean'], '>6.3f')} "
              f"{fmt(r['ik_ms_p95'], '>7.3f')} {fmt(r['ik_iterations_mean'], '>6.2f')}")
        print(f"{'':<11} peak torque / rating per joint: {r['peak_torque_over_effort']}, "
              f"largest tracking error {r['max_tracking_error_mrad']:.2f} mrad")
        for e in r["errors"]:
            print(f"    error: {e}")
    o = overall
    print(f"{'overall':<11} {100 * o['success_rate']:>7.1f}% {fmt(o['mean_cycle_s'], '>8.3f')} "
          f"{fmt(o['cycles_per_min'], '>8.1f')} {fmt(o['ratio_to_optimal'], '>6.3f')} {'':>9} "
          f"{fmt(o['ik_ms_mean'], '>6.3f')}")
    print("ratio = cycle time / time-optimal time of the same joint segments under the same "
          f"limits; wall {o['wall_s']:.1f} s")
    return 0
