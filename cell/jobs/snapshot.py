"""``cell snapshot``: run the conveyor until a part stops at the pick zone and save a view.

Writes ``rgb.png`` (the sensor's image), ``depth.npy`` (float32 metres), ``seg.npy``
(int32 part ids, 0 = no part), ``camera.json`` (true K, dist, T_world_camera in OpenCV
axes) and ``truth.json`` (every part on stage: id, kind, material, colour, defect, world
position, quaternion wxyz, yaw); with ``--save-xml`` also ``cell.xml``.

The output folder is written whole or not at all: the set is written into a staging
folder beside it (``OUT.tmp-XXXXXXXX``), every write checked, and then swapped into
place (the old folder is renamed aside to ``OUT.old-XXXXXXXX``, the new one renamed
to ``OUT``, the old one removed). A run that fails for any reason removes its staging
folder and any parent folders it created, and leaves an existing ``OUT`` as it was.
Policy for an existing ``OUT``: it is replaced as a set only when it holds nothing but
snapshot outputs (the names above), so no file of an earlier run survives beside the new
ones; a folder holding any other entry is refused before the run, and never touched.
``OUT`` may not be the current folder or one above it.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from cell.errors import SimError
from cell.jobs.snapshot_folder import OUTPUTS, OutputSet, check_out
from cell.options import Parser, int_in
from cell.scenario import Scenario, load_scenario
from cell.sim.world import World
from cell.text import escape

__all__ = ["MAX_TIME", "OUTPUTS", "main", "truth_rows"]

MAX_TIME = 3600.0
"""Largest ``--time`` (simulated seconds): one simulated hour, a few minutes of wall time."""

_SEED = {f.name: f for f in dataclasses.fields(Scenario)}["seed"].metadata


def truth_rows(world: World) -> list[dict]:
    """Ground truth of every part on stage (spawned and not fallen off the belt's end into
    the catch bin; for scoring and for files a user compares)."""
    rows = []
    for part in world.on_stage:
        pos, quat = world.part_pose(part.id)
        rows.append({
            "id": part.id, "kind": part.kind, "material": part.material, "colour": part.colour,
            "defect": part.defect, "position": pos.tolist(), "quat": quat.tolist(),
            "yaw": world.part_yaw(part.id),
        })
    return rows


# --- options ----------------------------------------------------------------------------

def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 0.0 <= value <= MAX_TIME):
        raise argparse.ArgumentTypeError(
            f"must be a finite number of seconds in [0, {MAX_TIME:g}], got {text!r}")
    return value + 0.0  # -0 becomes 0


def _parser() -> argparse.ArgumentParser:
    p = Parser(prog="cell snapshot", description=__doc__.splitlines()[0].replace("``", ""))
    p.add_argument("scenario", help="scenario TOML file")
    p.add_argument("--camera", default="overhead", choices=("overhead", "wrist"),
                   help="the camera whose view is saved (default overhead; the wrist camera "
                   "looks from the arm's home pose)")
    p.add_argument("--seed", type=int_in(int(_SEED["lo"]), int(_SEED["hi"])), default=None, metavar="N",
                   help=f"override the scenario's seed ({_SEED['lo']} to {_SEED['hi']})")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key (dotted for sections); repeatable")
    p.add_argument("--time", type=_seconds, default=None, metavar="S",
                   help=f"run S simulated seconds (0 to {MAX_TIME:g}) instead of waiting for the "
                        "pick zone")
    p.add_argument("--out", required=True,
                   help="output folder: created, or replaced as a whole if it holds only the "
                        "files of an earlier snapshot")
    p.add_argument("--save-xml", action="store_true",
                   help="also write the model as built as cell.xml (geometry, cameras, every part "
                   "at its waiting slot, lights off: not the snapshot's state, which truth.json holds)")
    return p


def _write_json(path: Path, data: object) -> None:
    try:
        text = json.dumps(data, indent=2, allow_nan=False) + "\n"
    except ValueError:
        raise ValueError("a value is NaN or infinite (not valid JSON)") from None
    path.write_text(text)


def _npy(array: np.ndarray) -> Callable[[Path], object]:
    return lambda path: np.save(path, array)


def _png(bgr: np.ndarray) -> Callable[[Path], object]:
    """A writer of ``bgr`` (uint8, H x W x 3) as PNG: encoded in memory and written by
    Python, so a path that is not UTF-8 never reaches OpenCV (whose ``imwrite`` crashes
    on one)."""
    def write(path: Path) -> bool:
        ok, data = cv2.imencode(".png", bgr)
        if ok:
            path.write_bytes(data.tobytes())
        return bool(ok)

    return write


# --- the command ------------------------------------------------------------------------

def _run_for(world: World, seconds: float) -> None:
    """Simulate ``seconds``, one simulated second at a time, with a progress line on
    stderr every 5 s of wall time (only long runs show one; quiet when not a terminal)."""
    steps = max(0, round(seconds / world.model.opt.timestep))
    chunk = max(1, round(1.0 / world.model.opt.timestep))
    done, shown = 0, time.perf_counter()
    while done < steps:
        world.step(min(chunk, steps - done))
        done = min(steps, done + chunk)
        if sys.stderr.isatty() and time.perf_counter() - shown >= 5.0:
            print(f"  ... {world.time:.0f} / {seconds:g} s simulated, {world.spawned} spawned, "
                  f"{world.caught} caught", file=sys.stderr, flush=True)
            shown = time.perf_counter()


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    scenario = load_scenario(args.scenario, overrides=args.overrides, seed=args.seed)
    target = check_out(args.out)
    t0 = time.perf_counter()
    outputs = OutputSet(args.out, target)
    try:
        world = World.build(scenario)
        try:
            if args.time is not None:
                _run_for(world, args.time)
                where = f"after {args.time:g} s"
            else:
                if scenario.conveyor.mode != "index":
                    raise SimError("conveyor.mode is 'continuous': nothing stops at the pick zone; "
                                   "pass --time S to take the picture after S seconds")
                if not world.run_until_part_at_pick():
                    raise SimError("no part reached the pick zone within 30 s of simulated time")
                where = f"part at the pick zone after {world.time:.2f} s"
            frame = world.render(args.camera)
            bgr = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR)
            outputs.write("rgb.png", _png(bgr))
            outputs.write("depth.npy", _npy(frame.depth.astype(np.float32)))
            outputs.write("seg.npy", _npy(frame.seg.astype(np.int32)))
            outputs.write("camera.json", lambda path: _write_json(path, frame.camera.to_dict()))
            outputs.write("truth.json", lambda path: _write_json(
                path, {"parts": truth_rows(world), "caught": list(world.caught_ids)}))
            if args.save_xml:
                outputs.write("cell.xml", world.save_xml)
            visible = sorted(int(i) for i in np.unique(frame.seg) if i > 0)
            spawned, caught = world.spawned, world.caught
        finally:
            world.close()
        outputs.commit()
    except BaseException:
        outputs.discard()
        raise
    print(f"snapshot of {escape(repr(scenario.name))} (seed {scenario.seed}, lighting "
          f"{scenario.lighting}, camera {args.camera}): {where}")
    print(f"  {spawned} parts spawned, {caught} fell off the belt's end into the catch bin; "
          f"visible in the image: {visible or 'none'}")
    print(f"  wrote {' '.join(outputs.written)} to {escape(args.out.rstrip('/') or '/')}/ "
          f"({time.perf_counter() - t0:.2f} s wall)")
    return 0
