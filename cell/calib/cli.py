"""``cell calibrate [SCENARIO] --out calib.json``: calibrate the cell's cameras in simulation.

The wrist camera (``--camera wrist``, the default): views of the table's checkerboard from
robot poses, then its intrinsics, distortion and mount on the flange (every OpenCV
hand-eye method, the best by a criterion that needs no ground truth, then a joint
refinement). The overhead camera (``--camera overhead``): views of a checkerboard plate on
the tool that the arm holds in front of it, then its intrinsics, distortion and pose in
the robot's base frame (eye-to-hand: SHAH and LI, the more consistent, then a joint
refinement). ``--camera all`` does both, wrist first, and the file holds both. The
calibration file is written atomically; the errors against the simulator's ground truth
are printed (``--report FILE`` writes them as JSON). Progress over the poses goes to
stderr when it is a terminal. Without SCENARIO the defaults are used.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from cell.calib.calfile import stage_calibration
from cell.calib.job import CAMERAS, run_calibration
from cell.calib.report import format_camera
from cell.errors import CalibrationError
from cell.files import StagedFiles, check_output_file
from cell.options import Parser, int_in
from cell.scenario import Scenario, load_scenario, scenario_from_dict
from cell.text import escape

__all__ = ["main"]

_SEED = {f.name: f for f in dataclasses.fields(Scenario)}["seed"].metadata


def _parser() -> argparse.ArgumentParser:
    p = Parser(prog="cell calibrate", description=__doc__.splitlines()[0])
    p.add_argument("scenario", nargs="?", default=None,
                   help="scenario TOML file (default: the built-in defaults)")
    p.add_argument("--camera", default="wrist", choices=CAMERAS,
                   help="camera to calibrate: wrist (eye-in-hand, the table's board), overhead "
                   "(eye-to-hand, a plate on the tool) or all (wrist, then overhead); default wrist")
    p.add_argument("--poses", type=int_in(3, 200), default=None, metavar="N",
                   help="robot poses (views) to capture; sets calibration.poses")
    p.add_argument("--seed", type=int_in(int(_SEED["lo"]), int(_SEED["hi"])), default=None, metavar="N",
                   help="override the scenario's seed")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key (dotted for sections); repeatable")
    p.add_argument("--out", required=True, help="calibration file to write (JSON)")
    p.add_argument("--report", default=None, help="also write the errors against ground truth as JSON")
    p.add_argument("--no-touch", action="store_true", help="skip the touch tests")
    return p


def _check_target(arg: str, option: str) -> Path:
    return check_output_file(arg, option, error=CalibrationError)


def _check_apart(out: Path, report: Path) -> None:
    """``--out`` and ``--report`` must be two files (the folder entries a rename replaces)."""
    if out.parent.resolve() / out.name == report.parent.resolve() / report.name:
        raise CalibrationError(f"--out {escape(repr(str(out)))} and --report "
                               f"{escape(repr(str(report)))} are the same file; name two files")


def _progress(stream) -> object:
    if not stream.isatty():
        return None

    def show(done: int, total: int, note: str) -> None:
        end = "\n" if done == total else ""
        stream.write(f"\rcalibrate: view {done}/{total} ({note})\x1b[K{end}")
        stream.flush()

    return show


def main(argv: list[str]) -> int:
    """Run ``cell calibrate`` with ``argv``; 0 on success (a ``CellError`` goes to the caller)."""
    args = _parser().parse_args(argv)
    overrides = list(args.overrides) + ([f"calibration.poses={args.poses}"] if args.poses else [])
    out = _check_target(args.out, "--out")
    report_path = _check_target(args.report, "--report") if args.report is not None else None
    if report_path is not None:
        _check_apart(out, report_path)
    if args.scenario:
        scenario = load_scenario(args.scenario, overrides=overrides, seed=args.seed)
    else:
        scenario = scenario_from_dict({}, overrides=overrides)
        if args.seed is not None:
            scenario = dataclasses.replace(scenario, seed=args.seed)
    run = run_calibration(scenario, camera=args.camera, progress=_progress(sys.stderr),
                          touch=not args.no_touch)
    report_text = json.dumps(run.report, indent=2, allow_nan=False) + "\n"  # (made before a write)
    with StagedFiles() as files:  # both files, or neither
        stage_calibration(files, out, run.calibration)
        if report_path is not None:
            files.add(report_path, report_text.encode("utf-8"), kind="report file",
                      error=CalibrationError)
        files.commit(error=CalibrationError)
    print(f"scenario {escape(scenario.name)!s}, seed {scenario.seed}, {scenario.calibration.poses} poses, "
          f"joint noise {scenario.calibration.joint_noise_deg:g} deg")
    for k, (name, camera_report) in enumerate(run.report["cameras"].items()):
        print(("\n" if k else "") + format_camera(name, camera_report))
    print(f"\nwrote {escape(str(out))}" + (f" and {escape(str(report_path))}" if report_path else "")
          + f" in {run.wall_s:.1f} s")
    return 0
