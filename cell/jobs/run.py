"""``cell run SCENARIO.toml``: the sort job, headless, with a summary, a report and a replay.

Without ``--calibration`` the overhead camera is calibrated first (as ``cell calibrate
--camera overhead --no-touch`` does, about 3 s) and, with ``--report``, that calibration is written
beside the report (``<report>.calibration.json``) for the next run to reuse. With
``--report`` the JSON report is written atomically, and ``detections.png`` (the last
capture with its detections drawn) goes beside it; ``--replay`` writes a rerun recording
(open it with ``rerun FILE.rrd``). Progress goes to stderr when it is a terminal; the
summary table to stdout.

Every file the run will write is checked before it starts (each can become a file, no
two of them, nor ``--calibration``, are the same file) and written only once the run has
succeeded: all of them made before the first is written, the recording moved into place
last.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

from cell.errors import JobError
from cell.files import StagedFiles, check_output_file
from cell.options import Parser, int_in
from cell.scenario import Scenario, load_scenario
from cell.text import escape

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
    return escape(str(beside)) if beside.exists() else "rerun"


@dataclass(frozen=True)
class _Output:
    """A file the run writes: its ``path`` and ``what`` names it to the user (an option,
    or a file written beside one)."""

    what: str
    path: Path


@dataclass(frozen=True)
class _Outputs:
    """The files a run writes (None: not written)."""

    report: _Output | None = None
    replay: _Output | None = None
    calibration: _Output | None = None  # beside the report, when this run calibrates
    image: _Output | None = None  # detections.png, beside the report (else the replay)

    def each(self) -> list[_Output]:
        return [o for o in (self.report, self.replay, self.calibration, self.image) if o is not None]


def _option(arg: str | None, option: str) -> _Output | None:
    return None if arg is None else _Output(option, check_output_file(arg, option, error=JobError))


def _beside(given: _Output, name: str, what: str) -> _Output:
    what = f"{what} written beside {given.what}"
    return _Output(what, check_output_file(str(given.path.with_name(name)), what, error=JobError))


def _entry(path: Path) -> Path:
    """The folder entry that writing ``path`` (a rename onto it) replaces."""
    return path.parent.resolve() / path.name


def _outputs(args: argparse.Namespace) -> _Outputs:
    """The files this run will write, each checked (``check_output_file``), no two of them
    the same file nor the ``--calibration`` read; a ``JobError`` naming both otherwise."""
    report, replay = _option(args.report, "--report"), _option(args.replay, "--replay")
    if replay is not None:
        from cell.replay import rerun_disabled  # (rerun loads only when a replay is asked for)

        if rerun_disabled():
            raise JobError(f"--replay {escape(repr(args.replay))}: rerun logging is disabled "
                           f"(RERUN={escape(os.environ['RERUN'])} in the environment): "
                           "unset it to write a replay")
    calibration = image = None
    if report is not None and args.calibration is None:
        calibration = _beside(report, report.path.stem + ".calibration.json", "the calibration")
    if report is not None or replay is not None:
        image = _beside(report or replay, "detections.png", "detections.png")
    outputs = _Outputs(report, replay, calibration, image)
    seen = {_entry(Path(args.calibration)): "--calibration"} if args.calibration else {}
    for out in outputs.each():
        if _entry(out.path) in seen:
            raise JobError(f"{seen[_entry(out.path)]} and {out.what} are the same file "
                           f"{escape(repr(str(out.path)))}; name different files")
        seen[_entry(out.path)] = out.what
    return outputs


def _check_camera(calibration: object, scenario: Scenario, where: str) -> None:
    """The calibration's overhead camera fits the scenario (its image size, and looking
    down on the plane ``vision.plane_z``); a ``JobError`` naming ``where`` otherwise."""
    from cell.errors import VisionError
    from cell.jobs.sort import overhead_model
    from cell.vision.steps.footprint import TablePlane

    try:
        TablePlane(overhead_model(calibration, scenario, where=where), scenario.vision.plane_z)
    except VisionError as exc:
        raise JobError(f"{where}: {exc}") from None


def main(argv: list[str]) -> int:
    """Run ``cell run`` with ``argv``; 0 on success (a ``CellError`` goes to the caller)."""
    args = _parser().parse_args(argv)
    outputs = _outputs(args)
    scenario = load_scenario(args.scenario, overrides=args.overrides, seed=args.seed)
    calibration = None
    if args.calibration is not None:
        from cell.calib.calfile import load_calibration

        calibration = load_calibration(args.calibration)  # checked before the long work
        _check_camera(calibration, scenario, f"--calibration {escape(repr(args.calibration))}")
    from cell.jobs.sort import run_sort

    progress = _progress(sys.stderr, "sort", "parts")
    calibrating = _progress(sys.stderr, "calibrate", "views") if calibration is None else None
    run = run_sort(scenario, calibration=calibration, progress=progress,
                   replay=outputs.replay.path if outputs.replay else None, commit_replay=False,
                   calibration_progress=calibrating)
    if progress is not None:
        sys.stderr.write("\n")
    try:
        written = _write(run, args, scenario, outputs)
    finally:
        if run.replay is not None:
            run.replay.abort()  # (nothing left to discard once committed)
    from cell.jobs.report import summary_table

    print(summary_table(run.report))
    if args.calibration is None:
        again = (f"; pass --calibration {escape(str(outputs.calibration.path))} to reuse it"
                 if outputs.calibration else "")
        print(f"\nno --calibration given: the overhead camera was calibrated first{again}")
    if written:
        print("\nwrote " + ", ".join(escape(str(p)) for p in written))
    if outputs.replay is not None:
        print(f"open the replay with: {_rerun()} {escape(str(outputs.replay.path))}")
    return 0


def _write(run: object, args: argparse.Namespace, scenario: Scenario, outputs: _Outputs) -> list[Path]:
    """Write the run's files, all or none (:class:`cell.files.StagedFiles`): every one
    staged beside its target and checked, then all renamed into place, the recording
    last, with Ctrl-C and SIGTERM held off; the paths written, in order."""
    report = run.report
    report["scenario_file"] = args.scenario
    report["calibration"]["file"] = (str(outputs.calibration.path) if outputs.calibration
                                     else args.calibration)
    text = json.dumps(report, indent=2, allow_nan=False) + "\n"
    image = _detections_png(run, scenario) if outputs.image else None
    written = []
    with StagedFiles() as files:
        if outputs.calibration is not None:
            from cell.calib.calfile import stage_calibration

            stage_calibration(files, outputs.calibration.path, run.calibration)
            written.append(outputs.calibration.path)
        if outputs.report is not None:
            files.add(outputs.report.path, text.encode("utf-8"), kind="report", error=JobError)
            written.append(outputs.report.path)
        if image is not None:
            files.add(outputs.image.path, image, kind="image", error=JobError)
            written.append(outputs.image.path)
        elif outputs.image is not None:  # no capture saw a part: no earlier run's image
            files.remove(outputs.image.path, kind="detections.png")
        if run.replay is not None:
            written.append(outputs.replay.path)
        files.commit(also=run.replay.commit if run.replay is not None else None, error=JobError)
    return written


def _detections_png(run: object, scenario: Scenario) -> bytes | None:
    """The PNG of the last capture that saw parts, its detections drawn; None if none did."""
    if run.last is None:
        return None
    from cell.jobs.policy import choose_bin
    from cell.jobs.report import draw_detections, encode_png

    dets = run.last.detections
    return encode_png(draw_detections(run.last.image, dets, camera=run.camera,
                                      bins=[choose_bin(d, scenario.sort) for d in dets]))
