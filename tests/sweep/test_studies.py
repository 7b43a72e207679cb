"""A tiny version of each study under scenarios/sweeps/ (two values per axis, one seed, two
parts; the sort cases one run each) runs through its job and its report: every run a row
with every parameter and metric, no failed run, no NaN, the study's plots and summary.md."""

from __future__ import annotations

import pytest

from cell.sweep.plan import plan_sweep
from cell.sweep.results import read_rows
from cell.sweep.runner import SweepOptions, run_plan
from cell.sweep.spec import load_sweep
from tests.sweep.helpers import STUDIES, Inline, shrink

PLOTS = {"threshold": ["threshold.png"], "lighting": ["lighting.png"], "sampling": ["sampling.png"],
         "compression": ["compression.png"], "smoothing": ["smoothing.png"], "matching": ["matching.png"],
         "edges": ["edges.png"]}


@pytest.mark.parametrize("study", sorted(PLOTS))
def test_a_tiny_study_runs_and_reports(study, tmp_path):
    plan = plan_sweep(shrink(load_sweep(STUDIES / f"{study}.toml")))
    assert 2 <= len(plan.runs) <= 24
    result = run_plan(plan, tmp_path, SweepOptions(progress=False), backend=Inline())
    assert (result.total, result.ran, result.failed) == (len(plan.runs), len(plan.runs), 0)
    header, rows = read_rows(tmp_path / "results.csv")
    assert header == plan.columns.names and len(rows) == len(plan.runs)
    assert {r["run_id"] for r in rows} == {r.run_id for r in plan.runs}
    assert "nan" not in (tmp_path / "results.csv").read_text().lower()
    for row in rows:
        assert row["error"] is None
        for key in plan.columns.params:
            assert key in row
    for name in PLOTS[study]:
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    summary = (tmp_path / "summary.md").read_text()
    assert summary.startswith(f"# {plan.spec.title}") and "## Findings" in summary
    for name in PLOTS[study]:
        assert f"]({name})" in summary
    assert set(result.files) == {*PLOTS[study], "summary.md"}
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
