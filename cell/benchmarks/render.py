"""``cell bench render``: rendering and physics speed of the cell.

Prints, for each camera, milliseconds per frame for RGB (under an unshadowed preset and
under ``raking``, the one preset with shadows), depth and segmentation, and the cost of
the sensor model as a ratio to the raw render; then our own post-processing alone, per
camera: the sensor model (``sensor_ms``) and the mapping of MuJoCo's raw segmentation to
part ids (``seg_map_ms``), each also as a ratio to the raw RGB render (``*_vs_raw_ratio``),
next to MuJoCo's raw segmentation render (``seg_raw_ms``); then the sensor model under
other settings on the overhead camera's frame (``sensor_variants``: median ms per frame
and the first frame's ms, which draws the noise bank and the distortion maps); then
physics steps per second with the arm and 10 parts on the belt and the real-time factor
(simulated / wall seconds). All times are medians over ``repeats`` frames after one
warm-up frame, in milliseconds. A ratio whose denominator measured zero is ``None``
(``null`` in JSON, ``-`` in the table).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from cell.benchmarks import fmt, int_in
from cell.errors import BenchError
from cell.options import Parser
from cell.scenario import scenario_from_dict

__all__ = ["MAX_REPEATS", "main", "parser", "run"]

RGB_TARGET_MS = 25.0  # the budget for one 640x480 RGB frame on a 2-core CPU
MAX_REPEATS = 10_000


def _ratio(a: float, b: float) -> float | None:
    return a / b if b > 0 else None


def _once_ms(fn) -> float:
    """Milliseconds of one call of ``fn``."""
    t0 = time.perf_counter()
    fn()
    return 1000.0 * (time.perf_counter() - t0)


def _ms(fn, repeats: int) -> float:
    """Median milliseconds per call of ``fn`` over ``repeats`` calls after a warm-up call."""
    fn()  # warm up (first frame uploads textures)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000.0 * float(np.median(times))


def _ms_after(produce, process, repeats: int) -> float:
    """Median milliseconds of ``process(produce())``, timing ``process`` alone.

    Each call gets a freshly produced input (a new render), so the caches are as cold as in
    a real frame loop; one warm-up call first.
    """
    process(produce())
    times = []
    for _ in range(repeats):
        x = produce()
        t0 = time.perf_counter()
        process(x)
        times.append(time.perf_counter() - t0)
    return 1000.0 * float(np.median(times))


def _post_processing(world, cam: str, repeats: int, *, raw_rgb_ms: float) -> dict:
    """Our own per-frame work on ``cam``'s frames, without MuJoCo's render call (ms).

    ``sensor_ms``: ``SensorModel.apply`` on a fresh raw RGB render (the scenario's sensor,
    the current preset's gain); ``seg_map_ms``: a fresh raw segmentation to part ids; both
    also as ratios to ``raw_rgb_ms``. ``seg_raw_ms``: MuJoCo's raw segmentation render.
    """
    rig = world.rig(cam)
    rng = np.random.default_rng(0)  # the bench's own generator: the world's stream is untouched
    gain = world.lighting.gain
    out = {
        "sensor_ms": _ms_after(lambda: rig.render_rgb(world.data),
                               lambda rgb: rig.sensor.apply(rgb, rng, gain=gain), repeats),
        "seg_raw_ms": _ms(lambda: rig.render_seg_raw(world.data), repeats),
        "seg_map_ms": _ms_after(lambda: rig.render_seg_raw(world.data), rig.part_ids, repeats),
    }
    out["sensor_vs_raw_ratio"] = _ratio(out["sensor_ms"], raw_rgb_ms)
    out["seg_map_vs_raw_ratio"] = _ratio(out["seg_map_ms"], raw_rgb_ms)
    return out


SENSOR_VARIANTS = {  # name -> SensorModel settings changed from the scenario's
    "defaults": {},
    "salt_pepper_bits": {"salt_pepper": 0.01, "bits": 4},
    "distortion": {"distortion": (-0.25, 0.08, 0.0, 0.0, 0.0)},
}


def _sensor_variants(world, repeats: int) -> dict:
    """The sensor model alone on the overhead camera's raw frames under ``SENSOR_VARIANTS``.

    For each: ``ms`` (median per fresh frame, the model alone) and ``first_frame_ms`` (a
    new model's first frame: it draws the noise bank, and the distortion maps if any),
    with the settings used.
    """
    import cv2

    from cell.sim.sensor import SensorModel

    rig = world.rig("overhead")
    rgb = rig.render_rgb(world.data)
    h, w = rgb.shape[:2]
    s = world.scenario.sensor
    gain = world.lighting.gain
    out = {}
    for name, changes in SENSOR_VARIANTS.items():
        settings = {"noise_std": s.noise_std, "salt_pepper": s.salt_pepper,
                    "distortion": tuple(s.distortion), "bits": s.bits, **changes}
        model = SensorModel(K=world.camera_model("overhead").K, width=w, height=h, **settings)
        rng = np.random.default_rng(0)
        px, py = model.padding()  # a distorting lens takes a larger ideal render

        def grown(x: np.ndarray, px: int = px, py: int = py) -> np.ndarray:
            return cv2.copyMakeBorder(x, py, py, px, px, cv2.BORDER_REPLICATE) if px else x

        first = _once_ms(lambda m=model, r=rng: m.apply(grown(rgb), r, gain=gain))
        out[name] = {"ms": _ms_after(lambda: grown(rig.render_rgb(world.data)),
                                     lambda x, m=model, r=rng: m.apply(x, r, gain=gain), repeats),
                     "first_frame_ms": first,
                     "settings": {**settings, "distortion": list(settings["distortion"])}}
    return out


def run(*, repeats: int = 30, steps: int = 5000, width: int = 640, height: int = 480) -> dict:
    """Measure and return the figures as a dict (see the module docstring)."""
    from cell.sim.world import World

    if not 1 <= repeats <= MAX_REPEATS:
        raise BenchError(f"repeats: must be 1 to {MAX_REPEATS}, got {repeats}")
    if steps < 1:
        raise BenchError(f"steps: must be at least 1, got {steps}")
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
            out.update(_post_processing(world, cam, repeats, raw_rgb_ms=out["rgb_raw_front_ms"]))
            cameras[cam] = out
        variants = _sensor_variants(world, repeats)
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
        "sensor_variants": variants,
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
    print("our post-processing alone, median ms per frame (x: ratio to the raw front RGB render)")
    print(f"{'camera':<10}{'sensor':>8}{'x':>7}{'seg raw':>9}{'id map':>8}{'x':>7}")
    for cam, r in result["cameras"].items():
        print(f"{cam:<10}{r['sensor_ms']:>8.2f}{fmt(r['sensor_vs_raw_ratio'], '>7.2f')}"
              f"{r['seg_raw_ms']:>9.2f}{r['seg_map_ms']:>8.2f}{fmt(r['seg_map_vs_raw_ratio'], '>7.2f')}")
    print("sensor model on the overhead frame: median ms per frame, first frame ms (draws the bank)")
    for name, v in result["sensor_variants"].items():
        st = v["settings"]
        what = (f"noise {st['noise_std']:g}, s&p {st['salt_pepper']:g}, bits {st['bits']}, "
                f"k1 {st['distortion'][0]:g}, k2 {st['distortion'][1]:g}")
        print(f"  {name:<18}{v['ms']:>7.2f}{v['first_frame_ms']:>8.1f}   {what}")
    p = result["physics"]
    print(f"physics: {fmt(p['steps_per_s'], '.0f')} steps/s with the arm and 10 parts "
          f"({p['dofs']} dofs), real-time factor {fmt(p['real_time_factor'], '.1f')}x")


def parser() -> argparse.ArgumentParser:
    p = Parser(prog="cell bench render", description="rendering and physics speed of the cell")
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
