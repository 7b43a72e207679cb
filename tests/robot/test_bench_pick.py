"""``cell bench pick``: the quick mode as a smoke test; the full run is slow."""

from __future__ import annotations

import json

import pytest

from cell.benchmarks import pick


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
