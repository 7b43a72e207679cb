"""``cell snapshot``: run the conveyor until a part stops at the pick zone and save a view.

Writes ``rgb.png`` (the sensor's image), ``depth.npy`` (float32 metres), ``seg.npy``
(int32 part ids, 0 = no part), ``camera.json`` (true K, dist, T_world_camera in OpenCV
axes) and ``truth.json`` (every part on stage: id, kind, material, colour, defect, world
position, quaternion wxyz, yaw).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import cv2
import numpy as np

from cell.errors import SimError
from cell.scenario import load_scenario
from cell.sim.world import World

__all__ = ["main", "truth_rows"]


def truth_rows(world: World) -> list[dict]:
    """Ground truth of every spawned part (for scoring and for files a user compares)."""
    rows = []
    for part in world.parts[: world.spawned]:
        pos, quat = world.part_pose(part.id)
        rows.append({
            "id": part.id, "kind": part.kind, "material": part.material, "colour": part.colour,
            "defect": part.defect, "position": pos.tolist(), "quat": quat.tolist(),
            "yaw": world.part_yaw(part.id),
        })
    return rows


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cell snapshot", description=__doc__.splitlines()[0])
    p.add_argument("scenario", help="scenario TOML file")
    p.add_argument("--camera", default="overhead", choices=("overhead", "wrist"))
    p.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key (dotted for sections); repeatable")
    p.add_argument("--time", type=float, default=None, metavar="S",
                   help="run S simulated seconds instead of waiting for the pick zone")
    p.add_argument("--out", required=True, help="output folder (created)")
    p.add_argument("--save-xml", action="store_true", help="also write the compiled model as cell.xml")
    return p


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    scenario = load_scenario(args.scenario, overrides=args.overrides, seed=args.seed)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    world = World.build(scenario)
    try:
        if args.time is not None:
            world.step(max(0, round(args.time / world.model.opt.timestep)))
            where = f"after {args.time:g} s"
        else:
            if scenario.conveyor.mode != "index":
                raise SimError("conveyor.mode is 'continuous': nothing stops at the pick zone; "
                               "pass --time S to take the picture after S seconds")
            if not world.run_until_part_at_pick():
                raise SimError("no part reached the pick zone within 30 s of simulated time")
            where = f"part at the pick zone after {world.time:.2f} s"
        frame = world.render(args.camera)
        cv2.imwrite(str(out / "rgb.png"), cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
        np.save(out / "depth.npy", frame.depth.astype(np.float32))
        np.save(out / "seg.npy", frame.seg.astype(np.int32))
        frame.camera.save(out / "camera.json")
        (out / "truth.json").write_text(json.dumps({"parts": truth_rows(world)}, indent=2) + "\n")
        if args.save_xml:
            world.save_xml(out / "cell.xml")
        visible = sorted(int(i) for i in np.unique(frame.seg) if i > 0)
    finally:
        world.close()
    print(f"snapshot of '{scenario.name}' (seed {scenario.seed}, lighting {scenario.lighting}, "
          f"camera {args.camera}): {where}")
    print(f"  {world.spawned} parts spawned, visible in the image: {visible or 'none'}")
    print(f"  wrote rgb.png depth.npy seg.npy camera.json truth.json to {out}/ "
          f"({time.perf_counter() - t0:.2f} s wall)")
    return 0

