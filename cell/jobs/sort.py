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
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cell.camera import CameraModel
from cell.errors import GraspError, IKError, JobError, MotionError
from cell.jobs.detectors import load_detector
from cell.jobs.eye import Capture, Eye
from cell.jobs.policy import Attempts, choose_bin, grasp_kind, pick_candidates
from cell.jobs.score import PickRecord, Scorekeeper, metrics_of
from cell.scenario import Scenario
from cell.sim import layout

__all__ = ["SortRun", "overhead_model", "run_sort"]

Progress = Callable[[int, int, str], None]
_LEAD = 1.0  # s: about how long from an image to the cup reaching a part (continuous mode)
_IDLE = 0.1  # s: the wait before looking again when nothing can be picked (continuous mode)
_EMPTY_SPOT = 0.008  # m: a detection this near a placed part's spot means it is still there
_STATE_EVERY = 0.04  # s: the replay's 3D states, 25 per simulated second


@dataclass(frozen=True, eq=False)
class SortRun:
    """A finished run: the JSON-ready ``report``, the ``last`` capture that saw parts (for
    ``detections.png``), the calibrated ``camera`` model the job used and the
    ``calibration`` it came from."""

    report: dict
    last: Capture | None
    camera: CameraModel
    calibration: object


def overhead_model(calibration: object, scenario: Scenario, *, where: str) -> CameraModel:
    """The calibrated overhead camera of ``calibration`` (a ``CalibrationFile``), checked
    against the scenario's image size; ``JobError`` naming ``where`` otherwise."""
    if "overhead" not in calibration.names:
        raise JobError(f"{where}: holds no overhead camera (it has: "
                       f"{', '.join(calibration.names) or 'none'}); calibrate it with "
                       "'cell calibrate --camera overhead'")
    model = calibration.camera("overhead").camera_model()
    size = (scenario.camera.width, scenario.camera.height)
    if (model.width, model.height) != size:
        raise JobError(f"{where}: the overhead camera was calibrated at {model.width}x{model.height}, "
                       f"the scenario's images are {size[0]}x{size[1]}")
    return model


class _Job:
    """One run's state: the cell, the robot, the eye, the records and the timers."""

    def __init__(self, scenario: Scenario, camera: CameraModel, *, replay: object | None,
                 progress: Progress | None) -> None:
        from cell.robot.pick import PickPlace
        from cell.sim import World

        self.scenario, self.settings = scenario, scenario.sort
        self.timers = {"physics": 0.0, "render": 0.0, "detect": 0.0, "replay": 0.0}
        detector = load_detector(scenario.vision)  # (a bad name fails before the cell is built)
        self.world = World.build(scenario)
        self.replay = replay(self.world) if replay else None
        self.skill = PickPlace(self.world.model, self.world.data, self._step, scenario.robot)
        self.eye = Eye(self.world, camera, detector, scenario,
                       truth=self.replay is not None, timers=self.timers)
        self.keeper = Scorekeeper(self.world)
        self.records: list[PickRecord] = []
        self.attempts = Attempts(self.settings.attempts)
        self.progress = progress
        self.last: Capture | None = None
        self._to_verify: PickRecord | None = None
        self._let_go = 0
        self._all_out_at: float | None = None
        self._next_state = 0.0
        self._encoder = (self.world.time, self.world.belt_encoder())
        self._belt_speed = 0.0

    # --- time -------------------------------------------------------------------------
    def _step(self, n: int = 1) -> None:
        """Physics steps (timed), logging the replay's 3D state as time passes."""
        t0 = time.perf_counter()
        self.world.step(n)
        self.timers["physics"] += time.perf_counter() - t0
        if self.replay is not None and self.world.time >= self._next_state:
            t0 = time.perf_counter()
            self.replay.log_state(self.world.time, self.world)
            self._next_state = self.world.time + _STATE_EVERY
            self.timers["replay"] += time.perf_counter() - t0

    def _wait(self, seconds: float) -> None:
        self._step(max(1, round(seconds / self.world.model.opt.timestep)))

    def _measure_belt(self) -> float:
        """The belt's speed (m/s) from its encoder since the last reading (at least 0.05 s)."""
        t, e = self.world.time, self.world.belt_encoder()
        if t - self._encoder[0] >= 0.05:
            self._belt_speed = (e - self._encoder[1]) / (t - self._encoder[0])
            self._encoder = (t, e)
        return self._belt_speed

    # --- looking ----------------------------------------------------------------------
    def _look(self) -> Capture | None:
        cap = self.eye.look()
        if cap is None:
            self._event("the camera delivered only black frames; nothing acted on", "warning")
            return None
        if cap.detections or self.last is None:
            self.last = cap  # the last capture that saw something (for detections.png)
        if cap.retakes:
            self._event(f"{cap.retakes} black frame(s) retaken", "warning")
        if self.replay is not None:
            t0 = time.perf_counter()
            self.replay.log_capture(cap.t, rgb=cap.image, detections=cap.detections, seg=cap.seg,
                                    camera=self.eye.camera, preset=next(iter(cap.images)))
            self.timers["replay"] += time.perf_counter() - t0
        self._verify(cap)
        return cap

    def _verify(self, cap: Capture) -> None:
        """The second look: is the last placed part's spot (moved on with the belt) empty?"""
        record, self._to_verify = self._to_verify, None
        if record is None:
            return
        x, y = record.detection["position"]
        x += self.world.belt_encoder() - record.encoder
        still = any(d.position is not None and abs(d.position[0] - x) < _EMPTY_SPOT
                    and abs(d.position[1] - y) < _EMPTY_SPOT for d in cap.detections)
        record.verified = not still
        if still:
            self._event(f"pick {record.index}: the part still lies at its spot", "warning")

    def _candidates(self, cap: Capture, shift: float) -> list:
        enc = self.world.belt_encoder()
        return [d for d in pick_candidates(cap.detections, self.settings, shift=shift)
                if not self.attempts.given_up(d.position, enc)]

    # --- acting -----------------------------------------------------------------------
    def _pick(self, det: object, cap: Capture, *, vx: float = 0.0) -> None:
        from cell.robot.pick import PartTarget

        record = PickRecord(len(self.records) + 1, cap.t, det.to_dict(),
                            choose_bin(det, self.settings), encoder=self.world.belt_encoder())
        self.records.append(record)
        self.keeper.attach(record, det)  # scoring only: the job never reads what it matched
        target = PartTarget(grasp_kind(det), det.position[0], det.position[1], det.yaw,
                            record.bin, vx=vx, seen_at=cap.t)
        try:
            result = self.skill.run(target)
        except IKError as exc:
            record.result, record.message = "unreachable", str(exc)
        except GraspError as exc:
            record.result, record.message = ("lost" if exc.lost else "grasp_failed"), str(exc)
        except MotionError as exc:
            record.result, record.message = "blocked", str(exc)
        else:
            record.result, record.cycle_time = "placed", result.cycle_time
            self._to_verify = record
        if record.result not in ("placed", "lost"):
            self.attempts.failed(det.position, record.encoder)
            self._event(f"pick {record.index} ({det.kind}): {record.result}: {record.message}", "warning")
        self._after_pick()

    def _after_pick(self) -> None:
        placed = sum(r.result == "placed" for r in self.records)
        if self.replay is not None:
            self.replay.log_metrics(self.world.time, {
                "picks": float(len(self.records)), "placed": float(placed),
                "pick_success": placed / len(self.records)})
        if self.progress is not None:
            total = self.scenario.parts.count
            self.progress(min(placed + self._let_go, total), total,
                          f"{placed} placed, t = {self.world.time:.0f} s")

    def _event(self, text: str, level: str = "info") -> None:
        if self.replay is not None:
            self.replay.log_event(self.world.time, text, level=level)

    # --- the two modes ----------------------------------------------------------------
    def _wait_for_part(self) -> bool:
        """Index mode: run the belt until a part stops at the barrier (then let it settle);
        False when none comes within ``sort.arrival_timeout``."""
        conveyor = self.world.conveyor
        while conveyor.release > 0.0:  # a part let go rides on past the barrier first
            self._step(10)
        end = self.world.time + self.settings.arrival_timeout
        while not self.world.barrier_blocked:
            if self.world.time >= end or self._all_through(layout.BARRIER_X):
                return False
            self._step(10)
        self._wait(0.3)
        return True

    def _look_for_parts(self) -> tuple[Capture | None, list]:
        """Index mode: a look and its pick candidates; looked again (``sort.relooks``
        times, the sensor's noise differs each time) while a part blocks the barrier but
        none is found, or while the first candidate would be rejected as unsure."""
        for _ in range(self.settings.relooks + 1):
            cap = self._look()
            todo = self._candidates(cap, 0.0) if cap is not None else []
            unsure = bool(todo) and choose_bin(todo[0], self.settings) == "reject"
            if cap is None or not (unsure or (not todo and self.world.barrier_blocked)):
                break
        return cap, todo

    def run_index(self) -> None:
        while self._wait_for_part():
            for _ in range(4 * self.scenario.parts.count):
                cap, todo = self._look_for_parts()
                if not todo:
                    break
                self._pick(todo[0], cap)
            if self.world.barrier_blocked:  # what is left at the barrier cannot be picked
                self._let_go += 1
                self._event("a part at the barrier is let go", "warning")
                self.world.conveyor.release_part()

    def _all_through(self, x: float) -> bool:
        """Whether the feeder has put out its last part (its counter) and the belt has run
        far enough since (its encoder) to carry that part past ``x`` (m)."""
        if self._all_out_at is None and self.world.spawned == len(self.world.parts):
            self._all_out_at = self.world.belt_encoder()
        return (self._all_out_at is not None
                and self.world.belt_encoder() - self._all_out_at > x - layout.SPAWN_X + 0.03)

    def run_continuous(self) -> None:
        belt = layout.BELT_X[1] - layout.SPAWN_X
        limit = self.scenario.parts.count * (self.scenario.parts.spacing + belt) / max(
            self.scenario.conveyor.speed, 1e-3) + 60.0
        moved_at, last = self.world.time, self.world.belt_encoder()
        while self.world.time < limit and not self._all_through(layout.BELT_X[1]):
            if self.world.belt_encoder() != last:
                moved_at, last = self.world.time, self.world.belt_encoder()
            elif self.world.time - moved_at > self.settings.arrival_timeout:
                self._event("the belt has not moved for sort.arrival_timeout: the job ends", "warning")
                return
            cap = self._look()
            v = self._measure_belt()
            todo = self._candidates(cap, v * _LEAD) if cap is not None else []
            if todo:
                self._pick(todo[0], cap, vx=v)
            else:
                self._wait(_IDLE)


def run_sort(scenario: Scenario, *, calibration: object | str | Path | None = None,
             progress: Progress | None = None, replay: str | Path | None = None) -> SortRun:
    """Run the sort job of ``scenario``; returns a :class:`SortRun`.

    ``calibration``: a ``CalibrationFile``, a path to one, or None to calibrate the
    overhead camera first (its figures go into the report). ``replay``: write a rerun
    recording there. ``progress(done, total, note)`` follows the parts.
    """
    from cell.calib.calfile import CalibrationFile, load_calibration

    t_start = time.perf_counter()
    report_cal: dict = {}
    if calibration is None:
        from cell.calib.job import run_calibration

        cal_run = run_calibration(scenario, camera="overhead", touch=False)
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

        def recorder(world: object) -> object:
            return Replay(replay, world)

    t0 = time.perf_counter()
    job = _Job(scenario, camera, replay=recorder, progress=progress)
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
            job.replay.close()
    except BaseException:
        if job.replay is not None:
            job.replay.abort()
        raise
    finally:
        job.world.close()
    return SortRun(report, job.last, camera, calibration)


def _report(job: _Job, scenario: Scenario, *, wall: float, calibration: dict) -> dict:
    rows = job.keeper.rows(job.records)
    metrics, accounting = metrics_of(rows, job.records, sim_time=job.world.time, wall_time=wall)
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
        "wall_time_fractions": {k: v / wall if wall > 0 else None for k, v in spent.items()},
        "parts": rows,
        "picks": [dataclasses.asdict(r) for r in job.records],
    }
