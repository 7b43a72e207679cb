"""The sort report's figures, worked out by hand from rows the scorekeeper would write."""

from __future__ import annotations

import pytest

from cell.jobs.score import PickRecord, metrics_of


def _row(outcome: str, *, kind="hex_nut", material="metal", seen=("hex_nut", "metal"),
         error_mm=0.1, yaw_deg=1.0) -> dict:
    detection = None if seen is None else {"kind": seen[0], "material": seen[1]}
    return {"outcome": outcome, "truth": {"kind": kind, "material": material},
            "detection": detection, "position_error_mm": error_mm, "yaw_error_deg": yaw_deg}


def test_sort_accuracy_counts_every_part_of_the_run_spawned_or_not():
    rows = [_row("binned_correct") for _ in range(5)]
    metrics, accounting = metrics_of(rows, [], parts=10, sim_time=10.0, wall_time=1.0)
    assert metrics["sort_accuracy"] == 0.5
    assert accounting["not_spawned"] == 5 and accounting["spawned"] == 5


def test_classification_needs_kind_and_material_both_right():
    rows = [_row("binned_wrong", seen=("hex_nut", "plastic")), _row("binned_correct"),
            _row("rejected", seen=("washer", "metal")), _row("missed", seen=None)]
    metrics, accounting = metrics_of(rows, [], parts=4, sim_time=1.0, wall_time=1.0)
    assert metrics["classification_accuracy"] == pytest.approx(1 / 3)  # of the 3 seen
    assert (accounting["binned"], accounting["rejected"], accounting["missed"]) == (2, 1, 1)


def test_error_percentiles_and_pick_figures():
    rows = [_row("binned_correct", error_mm=e, yaw_deg=y)
            for e, y in ((0.1, 0.5), (0.1, 0.5), (0.1, 0.5), (0.1, 0.5), (5.0, 3.0))]
    rows.append(_row("binned_correct", error_mm=None, yaw_deg=None))  # a washer: no yaw
    records = [PickRecord(i, 0.0, {}, "metal", result="placed", cycle_time=2.0) for i in range(3)]
    records.append(PickRecord(4, 0.0, {}, "metal", result="grasp_failed"))
    metrics, _ = metrics_of(rows, records, parts=6, sim_time=30.0, wall_time=3.0)
    assert metrics["position_error_mm_p50"] == pytest.approx(0.1)
    assert metrics["position_error_mm_p95"] == pytest.approx(0.1 + 0.8 * 4.9)  # numpy's linear
    assert metrics["yaw_error_deg_p95"] == pytest.approx(0.5 + 0.8 * 2.5)
    assert metrics["pick_success"] == 0.75 and metrics["cycle_time_s_mean"] == 2.0
    assert metrics["parts_per_minute"] == pytest.approx(6.0) and metrics["real_time_factor"] == 10.0


def test_no_samples_give_none_not_nan():
    metrics, _ = metrics_of([], [], parts=0, sim_time=0.0, wall_time=0.0)
    assert all(v is None for k, v in metrics.items() if k not in ("sim_time_s", "wall_time_s"))
