"""``cell run SCENARIO.toml``: the sort job, headless, with a summary, a report and a replay.

Without ``--calibration`` the overhead camera is calibrated first (as ``cell calibrate
--camera overhead`` does, about 3 s) and, with ``--report``, that calibration is written
beside the report (``<report>.calibration.json``) for the next run to reuse. With
``--report`` the JSON report is written atomically, and ``detections.png`` (the last
capture with its detections drawn) goes beside it; ``--replay`` writes a rerun recording
(open it with ``rerun FILE.rrd``). Progress goes to stderr when it is a terminal; the
summary table to stdout.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import sys
from pathlib import Path

from cell.cli import printable
from cell.errors import JobError
from cell.files import atomic_write_bytes, atomic_write_text, check_output_file
from cell.options import Parser, int_in
from cell.scenario import Scenario, load_scenario

__all__ = ["main"]

_SEED = {f.name: f for f in dataclasses.fields(Scenario)}["seed"].metadata


def _parser() -> argparse.ArgumentParser:
    p = Parser(prog="cell run", description="run the sort job of a scenario: detect, pick, sort, report")
    p.add_argument("scenario", help="scenario TOML file (scenarios/sort*.toml)")
    p.add_argument("--seed", type=int_in(int(_SEED["lo"]), int(_SEED["hi"])), default=None, metavar="N",
                   help="override the scenario's seed")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key (dotted for sections); repeatable")
    p.add_argument("--calibration", default=None, metavar="FILE",
                   help="calibration file with the overhead camera (from cell calibrate or an "
                   "earlier run); default: calibrate first")
    p.add_argument("--report", default=None, metavar="FILE",
                   help="write the JSON report here (and detections.png and the calibration beside it)")
    p.add_argument("--replay", default=None, metavar="FILE",
                   help="write a rerun recording (.rrd) of the run here")
    return p


def _progress(stream, what: str, unit: str) -> object:
    """A one-line progress bar on ``stream`` when it is a terminal, else None."""
    if not stream.isatty():
        return None

    def show(done: int, total: int, note: str) -> None:
        width = 30
        filled = round(width * done / max(1, total))
        stream.write(f"\r{what} [{'#' * filled}{'.' * (width - filled)}] {done}/{total} {unit} "
                     f"({note})\x1b[K")
        stream.flush()

    return show


def _rerun() -> str:
    """How to call rerun's viewer here: ``rerun`` when it is on the PATH, else the one
    installed beside this Python (the project's .venv)."""
    if shutil.which("rerun"):
        return "rerun"
    beside = Path(sys.executable).parent / "rerun"
    return printable(str(beside)) if beside.exists() else "rerun"


def _beside(report: Path, name: str) -> Path:
    return report.with_name(name)


def main(argv: list[str]) -> int:
    """Run ``cell run`` with ``argv``; 0 on success (a ``CellError`` goes to the caller)."""
    args = _parser().parse_args(argv)
    report_path = check_output_file(args.report, "--report", error=JobError) if args.report else None
    replay_path = check_output_file(args.replay, "--replay", error=JobError) if args.replay else None
    scenario = load_scenario(args.scenario, overrides=args.overrides, seed=args.seed)
    calibration = None
    if args.calibration is not None:
        from cell.calib.calfile import load_calibration

        calibration = load_calibration(args.calibration)  # checked before the long work
    else:
        print("no --calibration given: calibrating the overhead camera first", file=sys.stderr)
    from cell.jobs.sort import run_sort

    progress = _progress(sys.stderr, "sort", "parts")
    calibrating = _progress(sys.stderr, "calibrate", "views") if calibration is None else None
    run = run_sort(scenario, calibration=calibration, progress=progress, replay=replay_path,
                   calibration_progress=calibrating)
    if progress is not None:
        sys.stderr.write("\n")
    report = run.report
    report["scenario_file"] = args.scenario
    report["calibration"]["file"] = args.calibration
    written = []
    if report_path is not None:
        if args.calibration is None:
            from cell.calib.calfile import write_calibration

            cal_path = _beside(report_path, report_path.stem + ".calibration.json")
            write_calibration(cal_path, run.calibration)
            report["calibration"]["file"] = str(cal_path)
            written.append(cal_path)
        atomic_write_text(report_path, json.dumps(report, indent=2, allow_nan=False) + "\n",
                          kind="report", error=JobError)
        written.append(report_path)
    folder = report_path or replay_path
    if folder is not None and run.last is not None:
        from cell.jobs.policy import choose_bin
        from cell.jobs.report import draw_detections, encode_png

        dets = run.last.detections
        image = draw_detections(run.last.image, dets, camera=run.camera,
                                bins=[choose_bin(d, scenario.sort) for d in dets])
        png = _beside(folder, "detections.png")
        atomic_write_bytes(png, encode_png(image), kind="image", error=JobError)
        written.append(png)
    if replay_path is not None:
        written.append(replay_path)
    from cell.jobs.report import summary_table

    print(summary_table(report))
    if written:
        print("\nwrote " + ", ".join(printable(str(p)) for p in written))
    if replay_path is not None:
        print(f"open the replay with: {_rerun()} {printable(str(replay_path))}")
    return 0
