"""The sort job: vision in the loop, from the conveyor to the bins.

``run_sort(scenario)`` runs one scenario headless. Without a calibration it first
calibrates the overhead camera (:func:`cell.calib.job.run_calibration`); the job then
sees the cell only through that calibrated camera model. Per stop of the belt:

1. **index**: the belt runs until a part breaks the light barrier, then stops (index
   mode); in continuous mode it never stops, and the arm meets each part where the
   belt's encoder says it will be;
2. **capture** (:mod:`cell.jobs.eye`): the overhead camera under the capture presets,
   retaken while the frames are black;
3. **detect** through the calibrated camera model (``vision.detector``);
4. **decide** (:mod:`cell.jobs.policy`): the part furthest downstream in the pick window,
   its bin (``reject`` for an unknown kind or material, a partial view or low confidence);
5. **pick and place** (:class:`cell.robot.PickPlace`): the vacuum switch tells whether the
   part was held and whether it arrived;
6. **verify**: the next look at the pick zone checks the spot is empty; a part the
   detector missed, or could not be picked, is looked for again after the next pick.

A part that cannot be picked in ``sort.attempts`` tries is let go: the belt is released
past the barrier and the part rides on; one that leaves the belt is ``missed``. The
decisions use only images, joint readings (inside the robot), the light barrier, the
belt's encoder, the vacuum switch and the calibration; the ground truth is read by
:mod:`cell.jobs.score`, only to score.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

from cell.camera import CameraModel
from cell.errors import JobError
from cell.jobs.eye import Capture
from cell.jobs.loop import Progress, SortLoop
from cell.jobs.score import metrics_of
from cell.scenario import Scenario, check_scenario

__all__ = ["SortRun", "overhead_model", "run_sort"]

_FOVY_TOLERANCE = 0.02  # relative: a calibrated field of view this far from camera.fovy is another lens


@dataclass(frozen=True, eq=False)
class SortRun:
    """A finished run: the JSON-ready ``report``, the ``last`` capture that saw parts (for
    ``detections.png``), the calibrated ``camera`` model the job used, the
    ``calibration`` it came from and, when ``run_sort`` was told not to commit it, the
    finished ``replay`` (a :class:`~cell.replay.Replay`) for the caller to ``commit`` or
    ``abort``."""

    report: dict
    last: Capture | None
    camera: CameraModel
    calibration: object
    replay: object | None = None


def overhead_model(calibration: object, scenario: Scenario, *, where: str) -> CameraModel:
    """The calibrated overhead camera of ``calibration`` (a ``CalibrationFile``), checked
    against the scenario's image size and field of view (``camera.fovy``, within 2 %: a
    calibration recovers it to a fraction of that, another lens is off by more); a
    ``JobError`` naming ``where`` otherwise."""
    if "overhead" not in calibration.names:
        raise JobError(f"{where}: holds no overhead camera (it has: "
                       f"{', '.join(calibration.names) or 'none'}); calibrate it with "
                       "'cell calibrate --camera overhead'")
    model = calibration.camera("overhead").camera_model()
    size = (scenario.camera.width, scenario.camera.height)
    if (model.width, model.height) != size:
        raise JobError(f"{where}: the overhead camera was calibrated at {model.width}x{model.height}, "
                       f"the scenario's images are {size[0]}x{size[1]}")
    fovy = math.degrees(2 * math.atan(model.height / (2 * model.K[1, 1])))
    if abs(fovy - scenario.camera.fovy) > _FOVY_TOLERANCE * scenario.camera.fovy:
        raise JobError(f"{where}: the overhead camera was calibrated with a vertical field of view "
                       f"of {fovy:.1f} deg (fy {model.K[1, 1]:.1f} px), the scenario's camera.fovy is "
                       f"{scenario.camera.fovy:g} deg: calibrate this camera again")
    return model


def run_sort(scenario: Scenario, *, calibration: object | str | Path | None = None,
             progress: Progress | None = None, replay: str | Path | None = None,
             commit_replay: bool = True, calibration_progress: Progress | None = None) -> SortRun:
    """Run the sort job of ``scenario``; returns a :class:`SortRun`.

    ``calibration``: a ``CalibrationFile``, a path to one, a ``CalibrationRun`` (its
    calibration), or None to calibrate the overhead camera first (its figures go into
    the report). ``replay``: write a rerun
    recording there; with ``commit_replay`` False it is finished but left under its
    temporary name, and ``SortRun.replay`` must be committed (or aborted) by the caller
    once its other outputs are written. ``progress(done, total, note)`` follows the parts and
    ``calibration_progress`` (the same form) the calibration's views.
    """
    from cell.calib.calfile import CalibrationFile, load_calibration
    from cell.calib.job import CalibrationRun
    from cell.jobs.detectors import load_detector

    check_scenario(scenario, "run_sort", JobError)
    if isinstance(calibration, CalibrationRun):
        calibration = calibration.calibration
    if not (calibration is None or isinstance(calibration, CalibrationFile | str | os.PathLike)):
        raise JobError(f"run_sort: argument 'calibration': expected a CalibrationFile, a path "
                       f"to one, a CalibrationRun or None, got {type(calibration).__name__}")
    t_start = time.perf_counter()
    detector = load_detector(scenario.vision)  # (a bad one fails before the calibration)
    report_cal: dict = {}
    if calibration is None:
        from cell.calib.job import run_calibration

        cal_run = run_calibration(scenario, camera="overhead", touch=False,
                                  progress=calibration_progress)
        calibration = cal_run.calibration
        report_cal = {"source": "calibrated in this run", "wall_s": cal_run.wall_s,
                      "report": cal_run.report["cameras"]["overhead"]}
        where = "the calibration of this run"
    elif isinstance(calibration, CalibrationFile):
        report_cal, where = {"source": "given"}, "the calibration given"
    else:
        where = str(calibration)
        report_cal = {"source": where}
        calibration = load_calibration(calibration)
    camera = overhead_model(calibration, scenario, where=where)
    recorder = None
    if replay is not None:
        from cell.replay import Replay

        key = json.dumps(calibration.to_dict(), sort_keys=True)  # (a run is its calibration too)

        def recorder(world: object) -> object:
            return Replay(replay, world, key=key)

    t0 = time.perf_counter()
    job = SortLoop(scenario, camera, replay=recorder, progress=progress, detector=detector)
    try:
        if scenario.conveyor.mode == "continuous":
            job.run_continuous()
        else:
            job.run_index()
        wall = time.perf_counter() - t0
        report = _report(job, scenario, wall=wall, calibration=report_cal)
        report["wall_s_with_calibration"] = time.perf_counter() - t_start
        if job.replay is not None:
            job.replay.log_metrics(job.world.time, {k: v for k, v in report["metrics"].items()
                                                    if isinstance(v, float)})
            for row in report["parts"]:  # (the scoring's verdict, for the viewer)
                truth = row["truth"]
                job.replay.log_event(job.world.time, f"part {row['id']} ({truth['kind']}, "
                                     f"{truth['finish']}): {row['outcome']}, ended in "
                                     f"{row['ended_in']}", level="info" if row["outcome"]
                                     == "binned_correct" else "warning")
            job.replay.finish()
            if commit_replay:
                job.replay.commit()
    except BaseException:
        if job.replay is not None:
            job.replay.abort()
        raise
    finally:
        job.world.close()
    return SortRun(report, job.last, camera, calibration,
                   replay=job.replay if not commit_replay else None)


def _report(job: SortLoop, scenario: Scenario, *, wall: float, calibration: dict) -> dict:
    rows = job.keeper.rows(job.records)
    metrics, accounting = metrics_of(rows, job.records, parts=len(job.world.parts),
                                     sim_time=job.world.time, wall_time=wall)
    ik = sum(t for t, _ in job.skill.ik.stats)
    spent = dict(job.timers, ik=ik)
    spent["other"] = max(0.0, wall - sum(spent.values()))
    return {
        "scenario": scenario.name,
        "seed": scenario.seed,
        "mode": scenario.conveyor.mode,
        "detector": scenario.vision.detector,
        "capture_presets": list(job.eye.presets),
        "calibration": calibration,
        "metrics": metrics,
        "accounting": accounting,
        "ended": job.ended,
        "wall_time_fractions": {k: v / wall if wall > 0 else None for k, v in spent.items()},
        "parts": rows,
        "picks": [dataclasses.asdict(r) for r in job.records],
    }
