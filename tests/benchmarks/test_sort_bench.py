"""``cell bench sort``: a smoke run prints strict JSON with every figure the issue asks for."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

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
