"""The ``sort`` job: the closed loop (``cell.jobs.sort.run_sort``), calibration included.

Each run is the sort job of its scenario through a calibrated overhead camera. The
calibration is computed once per worker process for each distinct calibration set-up and
reused: the scenario with ``job.calibration_seed`` as its seed and
``job.calibration_lighting`` as its light (a cell is calibrated once, under one light,
and then sorts under whatever light the study sets), the sections that do not touch a
calibration set to defaults. A calibration costs about 5 s here, a 3-part sort about
0.6 s, so calibrating in every run would cost ten times the runs themselves; and since
the calibration is a function of that set-up alone, a run's result does not depend on
which worker ran it.

Figures: the sort report's ``metrics`` (sort and classification accuracy, pick success,
position error p50/p95, yaw error p95, mean cycle time, parts per minute, simulated time)
and its ``accounting`` (spawned, not spawned, binned, binned correct and wrong, rejected,
missed, dropped). Timings: the job's ``wall_time_s`` and ``real_time_factor``, and
``calibration_s`` (the worker's calibration, 0 when it was reused).
"""

from __future__ import annotations

import dataclasses
import time
from collections import OrderedDict
from dataclasses import dataclass

from cell.catalogue import LIGHTING_PRESETS
from cell.config import check, setting
from cell.scenario import Scenario

__all__ = ["METRICS", "TIMINGS", "Settings", "calibration_scenario", "measure", "prepare", "scene_key"]

_REPORT_METRICS = ("sort_accuracy", "classification_accuracy", "pick_success",
                   "position_error_mm_p50", "position_error_mm_p95", "yaw_error_deg_p95",
                   "cycle_time_s_mean", "parts_per_minute", "sim_time_s")
_ACCOUNTING = ("spawned", "not_spawned", "binned", "binned_correct", "binned_wrong", "rejected",
               "missed", "dropped")
METRICS = _REPORT_METRICS + _ACCOUNTING
TIMINGS = ("wall_time_s", "real_time_factor", "calibration_s")
_KEPT = 4  # calibrations a worker keeps
_CALIBRATIONS: OrderedDict = OrderedDict()


@dataclass(frozen=True)
class Settings:
    """The sort job's parameters (``[job]``)."""

    calibration_seed: int = setting(0, lo=0, hi=2**63 - 1,
                                    doc="seed of the overhead camera's calibration the runs share")
    calibration_lighting: str = setting("front", choices=tuple(LIGHTING_PRESETS),
                                        doc="the lighting preset the cell is calibrated under")

    def __post_init__(self) -> None:
        check(self, "job")  # (built in code too: cell.config.check)



def calibration_scenario(scenario: Scenario, settings: Settings) -> Scenario:
    """The scenario the shared calibration is computed from (see the module docstring)."""
    default = Scenario()
    return dataclasses.replace(
        scenario, name=default.name, seed=settings.calibration_seed,
        lighting=settings.calibration_lighting, vision=default.vision, capture=default.capture,
        sort=default.sort, faults=default.faults)


def scene_key(scenario: Scenario, settings: Settings) -> None:
    return None  # each run builds its own cell


def prepare(scenario: Scenario, settings: Settings) -> None:
    return None


def _calibration(scenario: Scenario, settings: Settings) -> tuple[object, float]:
    key = calibration_scenario(scenario, settings)
    if key in _CALIBRATIONS:
        _CALIBRATIONS.move_to_end(key)
        return _CALIBRATIONS[key], 0.0
    from cell.calib.job import run_calibration

    t0 = time.perf_counter()
    calibration = run_calibration(key, camera="overhead", touch=False).calibration
    _CALIBRATIONS[key] = calibration
    while len(_CALIBRATIONS) > _KEPT:
        _CALIBRATIONS.popitem(last=False)
    return calibration, time.perf_counter() - t0


def measure(scene: None, scenario: Scenario, settings: Settings) -> dict:
    from cell.jobs.sort import run_sort

    calibration, spent = _calibration(scenario, settings)
    report = run_sort(scenario, calibration=calibration).report
    metrics, accounting = report.get("metrics", {}), report.get("accounting", {})
    out = {k: metrics.get(k) for k in _REPORT_METRICS}
    out.update({k: accounting.get(k) for k in _ACCOUNTING})
    out.update(wall_time_s=metrics.get("wall_time_s"), real_time_factor=metrics.get("real_time_factor"),
               calibration_s=spent)
    return out
