"""The sort job's loop: one run's cell, robot, eye, decisions and records (``SortLoop``).

:func:`cell.jobs.sort.run_sort` builds a ``SortLoop`` and runs one of its two modes:

- ``run_index``: the belt runs until a part breaks the light barrier and stops (latched:
  :mod:`cell.sim.conveyor`); while it stands still (its encoder does not count) the arm
  picks every part it can from the pick window (looking again after each pick, and once
  more while unsure), giving the belt its go-ahead as each part leaves the belt in the
  cup, then lets go of whatever still blocks the barrier;
- ``run_continuous``: the belt never stops; the arm meets each part where the belt's
  encoder says it will be when the cup gets there.

The loop reads only images (through :class:`~cell.jobs.eye.Eye`), the light barrier, the
belt's encoder, the vacuum switch (inside :class:`~cell.robot.PickPlace`), the feeder's
counter and the calibrated camera model. :class:`~cell.jobs.score.Scorekeeper` is handed
each pick to score; nothing it holds flows back into a decision.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from cell.camera import CameraModel
from cell.errors import GraspError, IKError, MotionError
from cell.jobs.detectors import load_detector
from cell.jobs.eye import Capture, Eye
from cell.jobs.policy import Attempts, choose_bin, grasp_kind, pick_candidates
from cell.jobs.score import COMPLETED, PickRecord, Scorekeeper
from cell.scenario import Scenario
from cell.sim import layout

__all__ = ["Progress", "SortLoop"]

Progress = Callable[[int, int, str], None]
_LEAD = 1.0  # s: about how long from an image to the cup reaching a part (continuous mode)
_IDLE_TRAVEL = 0.02  # m: continuous mode, nothing in reach: look again after this much belt
_IDLE_WAIT = (0.05, 0.5)  # s: ... but no sooner and no later than these
_EMPTY_SPOT = 0.008  # m: a detection this near a placed part's spot means it is still there
_STATE_EVERY = 0.04  # s: the replay's 3D states, 25 per simulated second
_STILL_CHECK = 0.02  # s: index mode watches the encoder this long before it picks
# index mode: a part comes to the barrier within the belt's run from the feeder to it plus
# one spacing (the feeder puts a part out per spacing of belt run), with this much slack
# (a part slips a little on the belt, a touching pair is longer)
_ARRIVAL_SLACK = (1.2, 0.05)  # factor, m


class SortLoop:
    """One run's state: the cell, the robot, the eye, the records and the timers.

    ``replay``: a callable making the run's :class:`~cell.replay.Replay` from the world,
    or None; ``progress(done, total, note)`` follows the parts; ``detector``: the one
    :func:`~cell.jobs.detectors.load_detector` made (default: made here)."""

    def __init__(self, scenario: Scenario, camera: CameraModel, *, replay: object | None,
                 progress: Progress | None, detector: object | None = None) -> None:
        from cell.robot.pick import PickPlace
        from cell.sim import World

        t_setup = time.perf_counter()
        self.scenario, self.settings = scenario, scenario.sort
        self.timers = {"setup": 0.0, "physics": 0.0, "render": 0.0, "detect": 0.0, "replay": 0.0}
        if detector is None:
            detector = load_detector(scenario.vision)  # (a bad name fails before the cell is built)
        self.world = World.build(scenario)
        try:
            t0 = time.perf_counter()
            self.replay = replay(self.world) if replay else None  # (logs the cell's geometry)
            self.timers["replay"] += time.perf_counter() - t0
            self.skill = PickPlace(self.world.model, self.world.data, self._step, scenario.robot)
            self.timers["setup"] = time.perf_counter() - t_setup - self.timers["replay"]
            self.eye = Eye(self.world, camera, detector, scenario, truth=self.replay is not None,
                           timers=self.timers, step=self._step)
        except BaseException:
            self.world.close()  # (its renderers' GL contexts)
            raise
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
        self.ended = COMPLETED  # or why the job ended before

    # --- time -------------------------------------------------------------------------
    def _step(self, n: int = 1) -> None:
        """Physics steps (timed), logging the replay's 3D state every ``_STATE_EVERY`` s of
        simulated time (the steps run in chunks that end at those times)."""
        if self.replay is None:
            t0 = time.perf_counter()
            self.world.step(n)
            self.timers["physics"] += time.perf_counter() - t0
            self._watch_feeder()
            return
        dt = self.world.model.opt.timestep
        while n > 0:
            chunk = min(n, max(1, round((self._next_state - self.world.time) / dt)))
            t0 = time.perf_counter()
            self.world.step(chunk)
            self.timers["physics"] += time.perf_counter() - t0
            self._watch_feeder()
            n -= chunk
            if self.world.time >= self._next_state - dt / 2:
                self._log_state()

    def _watch_feeder(self) -> None:
        """Note the belt's encoder when the feeder's counter reaches its last part, read
        after every run of physics steps (a pick's included): the end of the job counts the
        belt's run from then (:meth:`_all_through`)."""
        if self._all_out_at is None and self.world.spawned == len(self.world.parts):
            self._all_out_at = self.world.belt_encoder()

    def _log_state(self) -> None:
        """The replay's 3D state now; the next one ``_STATE_EVERY`` s on (on the grid)."""
        t0 = time.perf_counter()
        self.replay.log_state(self.world.time, self.world)
        while self._next_state <= self.world.time + self.world.model.opt.timestep / 2:
            self._next_state += _STATE_EVERY
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
            self._log_state()  # (the 3D scene as the image shows it)
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
    def _pick(self, det: object, cap: Capture, *, vx: float = 0.0, second_look: str = "") -> None:
        from cell.robot.pick import PartTarget

        record = PickRecord(len(self.records) + 1, cap.t, det.to_dict(),
                            choose_bin(det, self.settings), encoder=self.world.belt_encoder(),
                            second_look=second_look)
        self.records.append(record)
        self.keeper.attach(record, det)  # scoring only: the job never reads what it matched
        target = PartTarget(grasp_kind(det), det.position[0], det.position[1], det.yaw,
                            record.bin, vx=vx, seen_at=cap.t)
        try:  # once the part is off the belt, the belt may bring the next (index mode)
            result = self.skill.run(target, lifted=self.world.conveyor.proceed)
        except IKError as exc:
            record.result, record.message = "unreachable", str(exc)
        except GraspError as exc:
            record.result, record.message = ("lost" if exc.lost else "grasp_failed"), str(exc)
        except MotionError as exc:
            record.result, record.message = "blocked", str(exc)
        else:
            record.result, record.cycle_time = "placed", result.cycle_time
            self._to_verify = record
        if record.result != "placed":
            self._event(f"pick {record.index} ({det.kind}): {record.result}: {record.message}", "warning")
        if record.result not in ("placed", "lost"):
            self.attempts.failed(det.position, record.encoder)
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

    def _end(self, why: str) -> None:
        """The job ends before every part came through: ``why`` goes into the report."""
        self.ended = why
        self._event(f"{why}: the job ends", "warning")

    # --- the two modes ----------------------------------------------------------------
    def _wait_for_part(self) -> bool:
        """Index mode: run the belt until a part stops at the barrier (then let it settle);
        False when the feeder's last part has come through, when the belt has run far
        enough to bring the next part and none came (the feeder's run to the barrier plus
        one spacing, with some slack), when the belt has not moved for
        ``sort.arrival_timeout`` (stopped), or when a part let go has not ridden on past
        the barrier within that time (jammed there). Each early end says why (``ended``)."""
        conveyor = self.world.conveyor
        conveyor.proceed()  # (the belt stays stopped after a stop at the barrier until then)
        end = self.world.time + self.settings.arrival_timeout
        while conveyor.release > 0.0:  # a part let go rides on past the barrier first
            if self.world.time >= end:
                self._end("a part let go has not left the barrier within sort.arrival_timeout")
                return False
            self._step(10)
        factor, slack = _ARRIVAL_SLACK
        reach = factor * (layout.BARRIER_X - layout.SPAWN_X + self.scenario.parts.spacing) + slack
        start = last = self.world.belt_encoder()
        moved_at = self.world.time
        while not self.world.barrier_blocked:
            if self._all_through(layout.BARRIER_X):
                return False
            encoder = self.world.belt_encoder()
            if encoder != last:
                moved_at, last = self.world.time, encoder
            elif self.world.time - moved_at > self.settings.arrival_timeout:
                self._end("the belt has not moved for sort.arrival_timeout")
                return False
            if encoder - start > reach:
                self._end(f"no part reached the light barrier in {reach:.2f} m of belt run")
                return False
            self._step(10)
        self._wait(0.3)
        return True

    def _look_for_parts(self) -> tuple[Capture | None, list, str]:
        """Index mode: a look, its pick candidates and the preset of a second look (or "");
        looked again (``sort.relooks`` times, the sensor's noise differs each time) while a
        part blocks the barrier but none is found, or while the first candidate would be
        rejected as unsure; a candidate still unsure only of its material then gets one
        look under ``sort.second_preset``."""
        for _ in range(self.settings.relooks + 1):
            cap = self._look()
            todo = self._candidates(cap, 0.0) if cap is not None else []
            unsure = (bool(todo) and choose_bin(todo[0], self.settings) == "reject"
                      and not getattr(todo[0], "mixed_with", ()))  # (rejected for its neighbours)
            if cap is None or not (unsure or (not todo and self.world.barrier_blocked)):
                break
        second = ""
        if todo and unsure and self._material_unsure(todo[0]):
            todo[0], second = self._second_opinion(todo[0])
        return cap, todo, second

    def _material_unsure(self, det: object) -> bool:
        """Whether only the material keeps ``det`` from its bin (its kind is sure), and a
        second preset is set that the captures did not use."""
        s = self.settings
        return (bool(s.second_preset) and s.second_preset not in self.eye.presets
                and not det.partial and det.kind_confidence >= s.min_kind_confidence
                and choose_bin(det, s) == "reject")

    def _second_opinion(self, det: object) -> tuple[object, str]:
        """(``det`` with its material as seen under ``sort.second_preset``, that preset) when
        that look is sure of it; else (``det`` as it was, "")."""
        preset = self.settings.second_preset
        other = self.eye.second_opinion(det, preset)
        if other is None or other.material_confidence < self.settings.min_material_confidence:
            self._event(f"{det.kind}: material still unsure under {preset}")
            return det, ""
        self._event(f"{det.kind}: {det.material} at {det.material_confidence:.2f}, under "
                    f"{preset} {other.material} at {other.material_confidence:.2f}")
        return other, preset

    def _belt_moving(self) -> bool:
        """Whether the belt's encoder counts over ``_STILL_CHECK`` seconds."""
        before = self.world.belt_encoder()
        self._wait(_STILL_CHECK)
        return self.world.belt_encoder() != before

    def run_index(self) -> None:
        while self._wait_for_part():
            for _ in range(4 * self.scenario.parts.count):
                if self._belt_moving():  # the barrier cleared during the last pick: the next
                    break  # part is on its way; it is picked when the belt has stopped
                cap, todo, second = self._look_for_parts()
                if not todo:
                    self._let_go_if_stuck()
                    break
                self._pick(todo[0], cap, second_look=second)
            else:
                self._let_go_if_stuck()

    def _let_go_if_stuck(self) -> None:
        """A part left at the barrier, looked at and not picked (found by no look, or
        given up on), is let go: the belt runs on past the barrier with it."""
        if self.world.barrier_blocked and not self._belt_moving():
            self._let_go += 1
            self._event("a part at the barrier is let go", "warning")
            self.world.conveyor.release_part()

    def _all_through(self, x: float) -> bool:
        """Whether the feeder has put out its last part (its counter) and the belt has run
        far enough since (its encoder, read when the counter got there: :meth:`_watch_feeder`)
        to carry that part past ``x`` (m)."""
        self._watch_feeder()
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
                self._end("the belt has not moved for sort.arrival_timeout")
                return
            cap = self._look()
            v = self._measure_belt()
            todo = self._candidates(cap, v * _LEAD) if cap is not None else []
            if todo:
                self._pick(todo[0], cap, vx=v)
            else:
                lo, hi = _IDLE_WAIT  # look again once the belt has brought 2 cm more into view
                self._wait(min(hi, max(lo, _IDLE_TRAVEL / max(v, 1e-6))))
        if not self._all_through(layout.BELT_X[1]):
            self._end(f"the run's time limit ({limit:.0f} s simulated, from the parts, their "
                      "spacing and the belt's speed) passed")
