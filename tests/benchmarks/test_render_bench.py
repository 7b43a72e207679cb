"""`cell bench render --quick` runs and reports every figure it promises."""

from __future__ import annotations

import json

import pytest

from cell.benchmarks.render import SENSOR_VARIANTS, parser, run
from cell.sim import layout


def test_render_bench_reports_each_camera_and_physics():
    result = run(repeats=2, steps=100)
    for cam in ("overhead", "wrist"):
        r = result["cameras"][cam]
        for key in ("rgb_front_ms", "rgb_raking_ms", "depth_ms", "seg_ms",
                    "sensor_ms", "seg_raw_ms", "seg_map_ms"):
            assert r[key] > 0
        assert r["sensor_overhead_ratio"] > 0
        assert r["sensor_vs_raw_ratio"] > 0 and r["seg_map_vs_raw_ratio"] > 0
    assert set(result["sensor_variants"]) == set(SENSOR_VARIANTS)
    for v in result["sensor_variants"].values():
        assert v["ms"] > 0 and v["first_frame_ms"] > 0
    assert result["physics"]["steps_per_s"] > 0 and result["physics"]["real_time_factor"] > 0
    json.dumps(result, allow_nan=False)  # strict JSON: no NaN or infinity anywhere


@pytest.mark.parametrize("repeats", ["0", "10001", "x"])
def test_render_bench_rejects_out_of_range_repeats(repeats, capsys):
    with pytest.raises(SystemExit) as exc:
        parser().parse_args(["--repeats", repeats])
    assert exc.value.code == 2


def test_real_time_factor_is_simulated_over_wall_time():
    physics = run(repeats=1, steps=200, width=64, height=48)["physics"]
    # simulated s per wall s = steps per wall s x simulated s per step
    assert physics["real_time_factor"] == pytest.approx(physics["steps_per_s"] * layout.TIMESTEP, rel=1e-6)
