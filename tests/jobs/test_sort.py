"""The sort job, closed loop: every sort scenario with 3 parts (default) and 20 (``-m slow``).

The overhead camera is calibrated once per module (as ``cell calibrate`` does) and the
calibration shared: the job acts on it, never on the simulator's camera.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from cell.jobs.loop import SortLoop
from cell.jobs.score import OUTCOMES, PickRecord
from cell.jobs.sort import run_sort
from cell.scenario import load_scenario

SCENARIOS = Path(__file__).parents[2] / "scenarios"
SORT = ("sort", "sort_back", "sort_dim", "sort_glare", "sort_continuous")


@pytest.fixture(scope="module")
def calibration():
    from cell.calib.job import run_calibration

    return run_calibration(load_scenario(SCENARIOS / "sort.toml"), camera="overhead",
                           touch=False).calibration


def _run(name: str, calibration, *overrides: str) -> dict:
    scenario = load_scenario(SCENARIOS / f"{name}.toml", overrides=list(overrides))
    return run_sort(scenario, calibration=calibration).report


def _check_accounting(report: dict, parts: int) -> None:
    a = report["accounting"]
    assert a["spawned"] == parts
    assert a["spawned"] == a["binned"] + a["rejected"] + a["missed"] + a["dropped"]
    assert a["binned"] == a["binned_correct"] + a["binned_wrong"]
    assert all(row["outcome"] in OUTCOMES for row in report["parts"])


@pytest.mark.parametrize("name", SORT)
def test_each_sort_scenario_sorts_three_parts(name, calibration):
    report = _run(name, calibration, "parts.count=3")
    _check_accounting(report, 3)
    m = report["metrics"]
    assert m["sort_accuracy"] >= 2 / 3, report["parts"]
    assert m["pick_success"] >= 0.5
    assert m["position_error_mm_p95"] < 2.0
    assert m["real_time_factor"] > 0 and m["sim_time_s"] > 0


def test_faults_are_recovered_or_accounted(calibration):
    report = _run("sort_faults", calibration, "parts.count=4")
    _check_accounting(report, 4)
    results = [p["result"] for p in report["picks"]]
    assert "grasp_failed" in results  # the 2nd grasp's vacuum failed, and was retried
    assert "lost" in results  # the 3rd grasp's part fell off the cup
    assert results.count("placed") >= 2
    assert report["parts"][2]["truth"]["flipped"]
    # a pick that failed with its part still there is retried from a fresh image
    failed = report["picks"][results.index("grasp_failed")]
    retried = report["picks"][results.index("grasp_failed") + 1]
    assert retried["t"] > failed["t"]


def test_same_seed_same_report(calibration):
    def decisions(report: dict) -> list:
        return [(p["t"], p["bin"], p["result"], p["detection"]["position"]) for p in report["picks"]]

    a = _run("sort", calibration, "parts.count=2")
    b = _run("sort", calibration, "parts.count=2")
    assert decisions(a) == decisions(b)
    assert [r["outcome"] for r in a["parts"]] == [r["outcome"] for r in b["parts"]]
    assert a["metrics"]["sim_time_s"] == b["metrics"]["sim_time_s"]


def test_a_part_the_robot_cannot_pick_is_let_go_and_missed(calibration):
    # every pick fails (the vacuum never seals): after 'attempts' tries the part rides on
    report = _run("sort", calibration, "parts.count=1", "faults.suction_fail=[1, 2]",
                  "sort.attempts=2")
    _check_accounting(report, 1)
    assert [p["result"] for p in report["picks"]] == ["grasp_failed", "grasp_failed"]
    assert report["parts"][0]["outcome"] == "missed"


def test_a_part_let_go_that_never_leaves_the_barrier_ends_the_job(calibration, monkeypatch):
    # a jam: the released part never clears the barrier (the release never runs out); the
    # job must end after sort.arrival_timeout, not wait for ever
    from cell.sim.conveyor import Conveyor

    monkeypatch.setattr(Conveyor, "release_part",
                        lambda self, distance=0.03: setattr(self, "release", float("inf")))
    report = _run("sort", calibration, "parts.count=2", "faults.suction_fail=[1, 2]",
                  "sort.attempts=2", "sort.arrival_timeout=15")
    _check_accounting(report, 2)
    assert [p["result"] for p in report["picks"]] == ["grasp_failed", "grasp_failed", "placed"]
    assert [p["outcome"] for p in report["parts"]] == ["missed", "binned_correct"]
    assert report["metrics"]["sim_time_s"] < 60


def test_low_confidence_goes_to_the_reject_bin(calibration):
    report = _run("sort", calibration, "parts.count=2", "sort.min_material_confidence=1.0")
    _check_accounting(report, 2)
    assert {p["bin"] for p in report["picks"]} == {"reject"}
    assert report["accounting"]["rejected"] == 2
    assert report["metrics"]["sort_accuracy"] == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("name", (*SORT, "sort_faults"))
def test_each_sort_scenario_sorts_twenty_parts(name, calibration):
    report = _run(name, calibration, "parts.count=20")
    _check_accounting(report, 20)
    if name != "sort_faults":
        assert report["metrics"]["sort_accuracy"] >= 0.95
        assert report["metrics"]["pick_success"] >= 0.95


def test_a_belt_that_never_moves_ends_the_job(calibration):
    report = _run("sort_continuous", calibration, "parts.count=2", "conveyor.speed=0",
                  "sort.arrival_timeout=5")
    _check_accounting(report, 1)  # the feeder put out one part; it never reached the arm
    assert report["metrics"]["sim_time_s"] < 10 and report["parts"][0]["outcome"] == "missed"
    # (the other part was reported nowhere, and the accuracy was over the one spawned)
    assert report["accounting"]["parts"] == 2 and report["accounting"]["not_spawned"] == 1
    assert report["ended"] == "the belt has not moved for sort.arrival_timeout"
    assert report["metrics"]["sort_accuracy"] == 0.0


def test_a_slow_belt_is_waited_for_and_an_early_end_is_said(calibration):
    # index mode waited sort.arrival_timeout (30 s) of time for a part: at 2 cm/s the
    # first one had not come yet, and the job ended with every part missed or unreported
    report = _run("sort", calibration, "parts.count=1", "conveyor.speed=0.02")
    _check_accounting(report, 1)
    assert report["ended"] == "every part came through"
    assert report["accounting"]["binned_correct"] == 1
    stopped = _run("sort", calibration, "parts.count=3", "faults.conveyor_stop=[1, 100]",
                   "sort.arrival_timeout=3")
    assert stopped["ended"] == "the belt has not moved for sort.arrival_timeout"
    a = stopped["accounting"]
    assert a["parts"] == 3 == a["spawned"] + a["not_spawned"] and a["not_spawned"] >= 1
    from cell.jobs.report import summary_table

    text = summary_table(stopped)
    assert "not_spawned" in text and "the job ended early: the belt has not moved" in text


def test_the_job_ends_once_the_last_part_is_through_not_a_belt_run_later(calibration):
    # the feeder's last part came out during a pick (the 7th at 0.78 m of belt, past the
    # 0.73 m the first rides to the barrier), and the parts then queued at the barrier; the
    # job counted the belt's run from its next wait for a part instead, after the last
    # pick, and ran the belt 7.5 s longer
    report = _run("sort", calibration, "parts.count=7", "parts.spacing=0.13")
    _check_accounting(report, 7)
    assert report["ended"] == "every part came through"
    last = report["picks"][-1]
    assert [p["result"] for p in report["picks"]] == ["placed"] * 7
    assert report["metrics"]["sim_time_s"] - (last["t"] + last["cycle_time"]) < 1.0


def test_index_mode_picks_only_while_the_belt_stands(calibration):
    # parts far apart: when a pick clears the barrier the belt runs on, and the next part
    # seen in the window is still moving; it must be picked only once the belt has stopped
    report = _run("sort", calibration, "parts.count=3", "parts.spacing=0.3")
    _check_accounting(report, 3)
    assert [p["result"] for p in report["picks"]] == ["placed"] * 3


def test_a_fast_belt_keeps_the_parts_that_roll_past_the_barrier_in_reach(calibration):
    # at 0.5 m/s a bolt lying across the belt rolls on when the belt stops and clears the
    # barrier by itself: the belt ran again and 3 of these 6 bolts were missed, never picked
    report = _run("sort", calibration, "conveyor.speed=0.5", 'parts.kinds=["bolt"]',
                  "parts.count=6", "seed=0")
    _check_accounting(report, 6)
    assert report["accounting"]["binned_correct"] == 6


class _UnsureFirst:
    """Our detector, but unsure of every material (confidence 0.55, under the job's 0.6)
    except during a second look: the case the second look is for, made on purpose (the
    detector is now sure on its own of nearly every part)."""

    second_look = False

    def __init__(self, settings):
        from cell.vision.detector import PartDetector

        self._detector = PartDetector(settings)

    def detect(self, image, camera):
        import dataclasses

        found = self._detector.detect(image, camera)
        if _UnsureFirst.second_look:
            return found
        return [dataclasses.replace(d, material_confidence=min(d.material_confidence, 0.55))
                for d in found]


def test_a_part_unsure_of_its_material_gets_a_second_look_under_another_light(calibration,
                                                                            monkeypatch):
    import sys
    import types

    from cell.jobs.eye import Eye

    module = types.ModuleType("unsure_detectors")
    module.UnsureFirst = _UnsureFirst
    monkeypatch.setitem(sys.modules, "unsure_detectors", module)
    first_opinion = Eye.second_opinion

    def second_opinion(self, det, preset):
        _UnsureFirst.second_look = True
        try:
            return first_opinion(self, det, preset)
        finally:
            _UnsureFirst.second_look = False

    monkeypatch.setattr(Eye, "second_opinion", second_opinion)
    report = _run("sort", calibration, "parts.count=2", "vision.detector=unsure_detectors:UnsureFirst")
    _check_accounting(report, 2)
    # each first look is unsure only of the material: the coaxial look decides it, and the
    # part goes to its material's bin, not the reject bin
    assert [p["second_look"] for p in report["picks"]] == ["coaxial", "coaxial"]
    assert all(p["bin"] == p["detection"]["material"] for p in report["picks"])
    assert [r["outcome"] for r in report["parts"]] == ["binned_correct"] * 2
    # without the second look (sort.second_preset = "") the same parts are rejected
    report = _run("sort", calibration, "parts.count=2", "vision.detector=unsure_detectors:UnsureFirst",
                  "sort.second_preset=")
    assert [p["bin"] for p in report["picks"]] == ["reject", "reject"]


def test_the_replay_logs_poses_every_40_ms_and_the_lost_picks(calibration, tmp_path, monkeypatch):
    # (poses came once per batch of steps, up to 0.3-0.4 s apart; a dropped part's pick,
    # 'lost', was no event)
    from cell.replay import Replay

    times, events = [], []
    log_state, log_event = Replay.log_state, Replay.log_event
    monkeypatch.setattr(Replay, "log_state", lambda self, t, w: (times.append(t), log_state(self, t, w)))
    monkeypatch.setattr(Replay, "log_event", lambda self, t, text, level="info": (
        events.append(text), log_event(self, t, text, level=level)))
    scenario = load_scenario(SCENARIOS / "sort.toml", overrides=["parts.count=2", "faults.drop=[1]"])
    report = run_sort(scenario, calibration=calibration, replay=tmp_path / "r.rrd").report
    assert max(b - a for a, b in zip(times, times[1:], strict=False)) <= 0.04 + 1e-9
    assert times[-1] >= report["metrics"]["sim_time_s"] - 0.04
    assert any(": lost: " in e for e in events)
    assert sum(e.startswith("part ") for e in events) == report["accounting"]["spawned"]


def test_run_sort_names_an_argument_of_the_wrong_type():
    from cell.errors import JobError

    with pytest.raises(JobError, match="argument 'scenario': expected a Scenario"):
        run_sort({"seed": 1})
    with pytest.raises(JobError, match="argument 'calibration': expected a CalibrationFile"):
        run_sort(load_scenario(SCENARIOS / "sort.toml"), calibration=42)


def _verify(encoder_now: float, seen_at: tuple[float, float]) -> bool:
    record = PickRecord(1, 0.0, {"position": [0.50, 0.0]}, "steel", encoder=0.10)
    events = []
    job = SimpleNamespace(_to_verify=record, world=SimpleNamespace(belt_encoder=lambda: encoder_now),
                          _event=lambda text, level="info": events.append(text))
    SortLoop._verify(job, SimpleNamespace(detections=[SimpleNamespace(position=seen_at)]))
    assert job._to_verify is None
    return record.verified


def test_the_spot_checked_after_a_pick_moves_on_with_the_belt():
    # the belt ran 50 mm since the pick's image: the part, not picked, is now 50 mm further on
    assert _verify(0.15, (0.55, 0.0)) is False
    assert _verify(0.15, (0.50, 0.0)) is True  # something where the part was: another part
    assert _verify(0.15, (0.55, 0.02)) is True  # 20 mm across the belt: another part
    assert _verify(0.10, (0.505, 0.005)) is False  # belt stood (index mode): within 8 mm
