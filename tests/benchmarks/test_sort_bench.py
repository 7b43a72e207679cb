"""``cell bench sort``: a smoke run prints strict JSON with every figure the issue asks for."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cell.benchmarks.sort import meets

ROOT = Path(__file__).parents[2]


def test_sort_bench_quick_json_has_the_figures():
    r = subprocess.run([sys.executable, "-m", "cell.cli", "bench", "sort", "--quick", "--json",
                        "--scenarios", "sort", "sort_faults"], capture_output=True, text=True, cwd=ROOT,
                       env={**os.environ, "MUJOCO_GL": "egl"}, timeout=900)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
    assert set(out["scenarios"]) == {"sort", "sort_faults"}
    for row in out["scenarios"].values():
        assert row["accounted"] and row["accounting"]["spawned"] == 3
        assert row["real_time_factor_replay"] > 0 and row["metrics"]["real_time_factor"] > 0
        assert set(row["wall_time_fractions"]) == {"setup", "physics", "render", "detect", "ik",
                                                   "replay", "other"}
        assert abs(sum(row["wall_time_fractions"].values()) - 1.0) < 0.05
    assert out["pooled"]["scenarios"] == ["sort"] and out["pooled"]["parts"] == 3
    assert isinstance(out["meets_required"], bool)


def _row(*, accounted=True, rtf_replay=3.0, rtf=4.0, ppm=12.0, pick=0.96) -> dict:
    return {"accounted": accounted, "real_time_factor_replay": rtf_replay,
            "metrics": {"real_time_factor": rtf, "parts_per_minute": ppm, "pick_success": pick}}


@pytest.mark.parametrize(("name", "row", "verdict"), [
    ("sort", _row(), True),
    ("sort", _row(ppm=9.0), False),              # below 10 parts per minute
    ("sort", _row(rtf=1.5), False),              # fast enough to pick, too slow to simulate
    ("sort", _row(accounted=False), False),      # a part lost
    ("sort", _row(rtf_replay=0.5), False),
    ("sort_faults", _row(ppm=1.0, pick=0.5), True),  # faults: only accounting and speed
    ("sort_faults", _row(rtf=1.0), False),
    ("sort_continuous", _row(ppm=1.0, pick=0.96), True),  # its own bar: 0.95, not 0.98
    ("sort_continuous", _row(pick=0.94), False),
])
def test_each_scenario_is_held_to_its_own_bars(name, row, verdict):
    assert meets(name, row) is verdict
