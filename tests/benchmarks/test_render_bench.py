"""`cell bench render --quick` runs and reports every figure it promises."""

from __future__ import annotations

from cell.benchmarks.render import run


def test_render_bench_reports_each_camera_and_physics():
    result = run(repeats=2, steps=100)
    for cam in ("overhead", "wrist"):
        r = result["cameras"][cam]
        for key in ("rgb_front_ms", "rgb_raking_ms", "depth_ms", "seg_ms"):
            assert r[key] > 0
        assert r["sensor_overhead_ratio"] > 0
    assert result["physics"]["steps_per_s"] > 0 and result["physics"]["real_time_factor"] > 0
