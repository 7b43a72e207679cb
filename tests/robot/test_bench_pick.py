"""``cell bench pick``: the quick mode as a smoke test; the full run is slow."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cell.benchmarks import pick
from cell.errors import CellError


def _run(capsys, argv):
    assert pick.main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_quick_bench_picks_every_kind(capsys):
    out = _run(capsys, ["--quick"])
    assert set(out["kinds"]) == {"washer", "hex_nut", "square_nut", "bolt", "l_bracket", "disc"}
    for figures in out["kinds"].values():
        assert figures["poses"] == 2
        assert figures["success_rate"] == 1.0
        assert 1.0 <= figures["ratio_to_optimal"] <= 1.5
        assert figures["errors"] == []


@pytest.mark.slow
def test_full_bench_meets_the_must_reach_figures(capsys):
    out = _run(capsys, [])
    o = out["overall"]
    assert o["success_rate"] >= 0.99
    assert o["ratio_to_optimal"] <= 1.5
    assert o["ik_ms_mean"] <= 1.0


def _targets(monkeypatch, **noise):
    """The targets ``run_kind`` hands the robot (the skill stubbed: no motion)."""
    from cell.robot.pick import PickPlace

    seen = []

    def record(self, target):
        seen.append((target.x, target.y, target.yaw))
        raise CellError("stub: no motion")

    monkeypatch.setattr(PickPlace, "run", record)
    pick.run_kind("washer", 12, 0, **noise)
    return np.array(seen)


def test_pose_noise_is_a_standard_deviation_in_mm_and_deg(monkeypatch):
    """--pose-noise-mm 5 / --yaw-noise-deg 3 shift the robot's targets by errors of std
    5 mm per axis and 3 deg (same poses as with no noise)."""
    exact = _targets(monkeypatch)
    noisy = _targets(monkeypatch, noise_mm=5.0, noise_deg=3.0)
    err = noisy - exact
    assert 3.5 < 1000 * np.std(err[:, :2]) < 6.5
    assert 1.5 < np.rad2deg(np.std(err[:, 2])) < 4.5


def test_cycles_per_minute_is_sixty_over_the_mean_cycle():
    figures = pick.run_kind("washer", 1, 0)
    assert figures["success_rate"] == 1.0
    assert figures["cycles_per_min"] == pytest.approx(60.0 / figures["mean_cycle_s"])
