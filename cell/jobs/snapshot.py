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
import os
import secrets
import shutil
import stat
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from cell.cli import printable
from cell.errors import JobError, SimError
from cell.files import signals_held
from cell.options import Parser, int_in
from cell.scenario import Scenario, load_scenario
from cell.sim.world import World

__all__ = ["MAX_TIME", "OUTPUTS", "main", "truth_rows"]

MAX_TIME = 3600.0
"""Largest ``--time`` (simulated seconds): one simulated hour, a few minutes of wall time."""

OUTPUTS = ("rgb.png", "depth.npy", "seg.npy", "camera.json", "truth.json", "cell.xml")
"""Every file a snapshot may write: the only entries an existing ``--out`` folder may hold."""

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


# --- the output folder ------------------------------------------------------------------

def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def _check_out(arg: str) -> Path:
    """The folder ``--out`` names, resolved; a ``JobError`` if it cannot take a snapshot.

    Checked before the run so a bad path fails at once: not empty, not the current folder
    (or one above it), an existing entry must be a folder holding only snapshot outputs,
    and the nearest existing ancestor must be a folder that can be written.
    """
    shown = f"--out {arg!r}"
    if not arg:
        raise JobError(f"{shown}: empty path; name the output folder")
    try:
        cwd = Path.cwd()
        target = Path(os.path.abspath(arg))
        resolved = target.resolve()  # follow links: the folder a link points to is the one replaced
        for path in (target, resolved):
            if path == cwd or path in cwd.parents:
                raise JobError(f"{shown}: is the current folder or holds it; name a folder inside it")
        target = probe = resolved
        while True:
            try:
                st = probe.stat()
                break
            except FileNotFoundError:
                probe = probe.parent
    except OSError as exc:  # a name too long, a loop of links, no permission to look
        raise JobError(f"{shown}: cannot be used: {_reason(exc)}") from None
    except (RuntimeError, ValueError) as exc:  # a loop of links (Python < 3.13), a NUL character
        raise JobError(f"{shown}: cannot be used: {exc}") from None
    if not stat.S_ISDIR(st.st_mode):
        if probe == target:
            raise JobError(f"{shown}: exists and is not a folder")
        raise JobError(f"{shown}: cannot be created: {str(probe)!r} is not a folder")
    if probe == target:
        if target == Path(target.anchor):
            raise JobError(f"{shown}: is a file system root; name a folder inside it")
        try:
            foreign = sorted(name for name in os.listdir(target) if name not in OUTPUTS)
        except OSError as exc:
            raise JobError(f"{shown}: cannot be read: {_reason(exc)}") from None
        if foreign:
            listed = ", ".join(repr(n) for n in foreign[:3]) + (", ..." if len(foreign) > 3 else "")
            raise JobError(f"{shown}: holds entries that are not snapshot outputs ({listed}); "
                            "name a new folder, or one written only by cell snapshot")
        need = [target, target.parent]
    else:
        need = [probe]
    for folder in need:
        if not os.access(folder, os.W_OK | os.X_OK):
            raise JobError(f"{shown}: cannot be written: no write permission in {str(folder)!r}")
    return target


class _OutputSet:
    """An output folder staged beside ``target`` and swapped into place on :meth:`commit`."""

    def __init__(self, arg: str, target: Path) -> None:
        self.arg, self.target = arg, target
        self.created: list[Path] = []  # parent folders this run made, outermost first
        self.staging: Path | None = None
        self.written: list[str] = []
        try:
            missing = []
            parent = target.parent
            while not parent.exists():
                missing.append(parent)
                parent = parent.parent
            for folder in reversed(missing):
                folder.mkdir()
                self.created.append(folder)
            self.staging = self._new_folder("tmp")
        except OSError as exc:
            self.discard()
            raise JobError(f"--out {arg!r}: cannot be created: {_reason(exc)}") from None

    def _new_folder(self, tag: str) -> Path:
        """A new empty folder ``<target name>.<tag>-XXXXXXXX`` beside the target."""
        stem = self.target.name[:200]
        while True:
            folder = self.target.parent / f"{stem}.{tag}-{secrets.token_hex(4)}"
            try:
                folder.mkdir()
                return folder
            except FileExistsError:
                continue

    def write(self, name: str, writer: Callable[[Path], object]) -> None:
        """Run ``writer(path)`` for ``name`` in the staging folder; any failure is a ``JobError``.

        A writer that returns ``False`` (as an image encoder does) has failed.
        """
        shown = repr(str(self.target / name))
        try:
            ok = writer(self.staging / name)
        except OSError as exc:
            raise JobError(f"cannot write {shown}: {_reason(exc)}") from None
        except ValueError as exc:  # json.dumps(allow_nan=False) and friends
            raise JobError(f"cannot write {shown}: {exc}") from None
        except cv2.error as exc:
            raise JobError(f"cannot write {shown}: OpenCV: {str(exc).strip().splitlines()[-1]}") from None
        if ok is False:
            raise JobError(f"cannot write {shown}: the image encoder failed")
        self.written.append(name)

    def commit(self) -> None:
        """Swap the staged set into place; the earlier folder, if any, is removed after.
        Ctrl-C and SIGTERM are held off meanwhile (:func:`cell.files.signals_held`): the
        swap happens whole, the earlier folder gone, before one takes effect."""
        with signals_held():
            self._swap()

    def _swap(self) -> None:
        """:meth:`commit`, its signals held."""
        target, aside = self.target, None
        _check_out(self.arg)  # again: the folder may have changed while the world ran
        try:
            if os.path.lexists(target):
                aside = self._new_folder("old")
                os.rename(target, aside)  # replaces the empty placeholder atomically
            try:
                os.rename(self.staging, target)
            except OSError as exc:
                if aside is not None:
                    try:
                        os.rename(aside, target)
                    except OSError:
                        raise JobError(f"--out {self.arg!r}: cannot be replaced: {_reason(exc)}; "
                                        f"the earlier output is now in {str(aside)!r}") from None
                    aside = None
                raise
        except OSError as exc:
            if aside is not None and aside.exists() and not any(aside.iterdir()):
                aside.rmdir()
            raise JobError(f"--out {self.arg!r}: cannot be replaced: {_reason(exc)}") from None
        self.staging, self.created = None, []
        if aside is not None:
            shutil.rmtree(aside, ignore_errors=True)
            if aside.exists():
                print(f"cell snapshot: warning: could not remove the earlier output "
                      f"{printable(repr(str(aside)))}", file=sys.stderr)

    def discard(self) -> None:
        """Remove the staging folder and the parents this run created (the run failed)."""
        if self.staging is not None:
            shutil.rmtree(self.staging, ignore_errors=True)
            self.staging = None
        for folder in reversed(self.created):
            try:
                folder.rmdir()
            except OSError:
                break
        self.created = []


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
    target = _check_out(args.out)
    t0 = time.perf_counter()
    outputs = _OutputSet(args.out, target)
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
    print(f"snapshot of {printable(repr(scenario.name))} (seed {scenario.seed}, lighting "
          f"{scenario.lighting}, camera {args.camera}): {where}")
    print(f"  {spawned} parts spawned, {caught} fell off the belt's end into the catch bin; "
          f"visible in the image: {visible or 'none'}")
    print(f"  wrote {' '.join(outputs.written)} to {printable(args.out.rstrip('/') or '/')}/ "
          f"({time.perf_counter() - t0:.2f} s wall)")
    return 0
