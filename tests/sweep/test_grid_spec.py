"""Sweep files: axes (lists, ranges, tables set together), cases, seeds and the plan of runs;
every bad key or value is one error naming the file and the key. No simulation here."""

from __future__ import annotations

import math
import tomllib

import pytest

from cell.errors import ScenarioError
from cell.sweep.errors import SweepError
from cell.sweep.grid import expand_range, parse_axes, product, size
from cell.sweep.plan import plan_sweep
from cell.sweep.spec import load_sweep, sweep_from_dict
from tests.sweep.helpers import TINY, write_tiny


def _spec(text: str, tmp_path):
    return sweep_from_dict(tomllib.loads(text), source=str(tmp_path / "s.toml"), folder=tmp_path)


def test_ranges_lists_and_single_values():
    assert expand_range({"from": 0, "to": 255, "step": 15}, "k", "f") == list(range(0, 256, 15))
    assert expand_range({"from": 1, "to": 4}, "k", "f") == [1, 2, 3, 4]
    assert expand_range({"from": 0.1, "to": 0.5, "step": 0.1}, "k", "f") == [0.1, 0.2, 0.3, 0.4, 0.5]
    # 0.3 / 0.1 is 2.9999999999999996 in floating point: the end is still a value
    assert expand_range({"from": 0, "to": 0.3, "step": 0.1}, "k", "f") == [0.0, 0.1, 0.2, 0.3]
    assert expand_range({"from": 0.0, "to": 1.0, "count": 5}, "k", "f") == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert expand_range({"from": 10, "to": 40, "count": 4}, "k", "f") == [10, 20, 30, 40]
    axes = parse_axes({"a": [1, 2], "b": "x", "c": {"from": 0, "to": 2}}, "f")
    assert [a.keys for a in axes] == [("a",), ("b",), ("c",)] and size(axes) == 6
    assert list(product(axes))[:2] == [{"a": 1, "b": "x", "c": 0}, {"a": 1, "b": "x", "c": 1}]


def test_a_list_of_tables_sets_keys_together_and_sections_flatten():
    axes = parse_axes({"camera": [{"width": 160, "height": 120}, {"width": 320, "height": 240}],
                       "vision": {"threshold": [1, 2]}}, "f")
    assert axes[0].keys == ("camera.width", "camera.height") and len(axes[0].values) == 2
    assert axes[1].keys == ("vision.threshold",)
    points = list(product(axes))
    assert points[0] == {"camera.width": 160, "camera.height": 120, "vision.threshold": 1}


@pytest.mark.parametrize(("table", "words"), [
    ({"a": []}, "no values"),
    ({"a": {"from": 3, "to": 1}}, "below 'from'"),
    ({"a": {"from": 0, "to": 1, "step": 0}}, "above 0"),
    ({"a": {"from": 0, "to": 1e9, "step": 1}}, "at most"),
    ({"a": {"from": 0, "to": 1, "step": 1, "count": 2}}, "at most one"),
    ({"a": [1.0, math.nan]}, "finite"),
    ({"a": {"from": math.inf, "to": 1}}, "finite"),
    ({"a": [{"x": 1}, 2]}, "mixes"),
    ({"a": [{"x": 1}, {"y": 2}]}, "same keys"),
    ({"a": [100, 100.0, 150]}, "key 'a' lists the value 100 twice"),  # (was one run, "3 values")
    ({"a": {"from": 0, "to": 10, "stp": 2}},  # (was "key 'a' is not a section")
     "range of key 'a': unknown key 'stp'; a range takes 'from', 'to' and 'step' or 'count'"),
    ({"a": [{"x": 1, "y": 2}, {"x": 1, "y": 2}]}, "lists the value {'a.x': 1, 'a.y': 2} twice"),
])
def test_bad_axes_name_the_key(table, words):
    with pytest.raises(SweepError, match=words) as info:
        parse_axes(table, "file.toml")
    assert "file.toml" in str(info.value) and "'a" in str(info.value)


@pytest.mark.parametrize("table", [
    {"from": -1e308, "to": 1e308, "step": 1.0},  # to - from overflows
    {"from": 0.0, "to": 1.0, "step": 1e-320},  # (to - from) / step overflows
    {"from": 0.0, "to": 1e308, "step": 1e-300},
])
def test_a_range_too_long_to_count_is_refused_naming_the_limit(table, tmp_path):
    with pytest.raises(SweepError, match="holds too many values to count; at most 100000") as info:
        parse_axes({"a": table}, "file.toml")
    assert "file.toml" in str(info.value) and "range of key 'a'" in str(info.value)
    with pytest.raises(SweepError, match="range of key 'seeds'.*at most 100000"):
        plan_sweep(_spec(f"[sweep]\nseeds = {{from = {table['from']!r}, to = {table['to']!r}, "
                         f"step = {table['step']!r}}}\n", tmp_path))


def test_a_count_range_over_the_whole_float_line_stays_finite():
    assert expand_range({"from": -1e308, "to": 1e308, "count": 3}, "k", "f") == [-1e308, 0.0, 1e308]
    assert expand_range({"from": -1e308, "to": 1e308, "count": 2}, "k", "f") == [-1e308, 1e308]


def test_cases_multiply_the_grid_and_replace_its_axes(tmp_path):
    spec = _spec(TINY, tmp_path)
    assert [c.job for c in spec.cases] == ["detect", "detect"]
    assert [tuple(k for a in c.axes for k in a.keys) for c in spec.cases] == [
        ("lighting", "vision.segmentation", "vision.threshold"), ("lighting", "vision.segmentation")]
    plan = plan_sweep(spec)
    assert len(plan.runs) == (2 * 2 + 2) * 2 and len({r.run_id for r in plan.runs}) == len(plan.runs)
    assert {r.scenario.seed for r in plan.runs} == {1, 2}
    assert plan.columns.params[:3] == ("lighting", "vision.segmentation", "vision.threshold")
    assert "job.gap_mm" in plan.columns.params and "recall" in plan.columns.metrics
    assert plan.columns.timings == ("detect_ms", "scene_s")
    override = _spec(TINY + '\n[[case]]\nlighting = "dim"\n"vision.segmentation" = "belt"\nseeds = [7]\n',
                     tmp_path)
    assert len(plan_sweep(override).runs) == len(plan.runs) + 1


def test_run_ids_are_stable_and_follow_the_parameters(tmp_path):
    a = {r.run_id for r in plan_sweep(_spec(TINY, tmp_path)).runs}
    assert a == {r.run_id for r in plan_sweep(_spec(TINY, tmp_path)).runs}
    changed = plan_sweep(_spec(TINY.replace('"parts.count" = 2', '"parts.count" = 3'), tmp_path))
    assert not a & {r.run_id for r in changed.runs}
    # a duplicate point (the belt case listed twice) is one run
    twice = plan_sweep(_spec(TINY + '\n[[case]]\n"vision.segmentation" = "belt"\n', tmp_path))
    assert {r.run_id for r in twice.runs} == a


def test_a_case_runs_another_job_with_its_own_seeds(tmp_path):
    text = TINY + '\n[[case]]\njob = "sort"\nseeds = [5]\nlighting = "front"\n"job.calibration_seed" = 3\n'
    plan = plan_sweep(_spec(text, tmp_path))
    sort = [r for r in plan.runs if r.job == "sort"]
    assert len(sort) == 1 and sort[0].scenario.seed == 5 and sort[0].settings.calibration_seed == 3
    assert "sort_accuracy" in plan.columns.metrics and "job.calibration_lighting" in plan.columns.params


@pytest.mark.parametrize(("text", "words"), [
    ('[sweep]\njob = "fly"\n', "unknown job 'fly'; valid: detect"),
    ('[sweep]\nreport = "nope"\n', "no report; valid: generic"),
    ('[sweep]\nseeds = [1, 1]\n', "twice"),
    ('[sweep]\nseeds = [-1]\n', "from 0 to 2**63-1"),
    ('[sweep]\ncolour = 1\n', "unknown key 'sweep.colour'"),
    ('[sweeps]\n', "unknown section 'sweeps'"),
    ('[grid]\nseed = [1, 2]\n', "'seed' is not a grid key"),
    ('[grid]\n"lighting.x" = [1]\n', "'lighting' is not a section"),
    ('[scenario]\n"parts.count" = 6\n[grid]\n"parts.count" = [2, 3]\n',  # (runs took 2 and 3:
     # summary.md said "fixed: parts.count = 6")
     "case 1: key 'parts.count' is both fixed in [scenario] and set in the grid or the case"),
    ('[job]\ngap_mm = 1.0\n[grid]\n"job.gap_mm" = [2.0, 3.0]\n',
     "key 'job.gap_mm' is both fixed in [job] and set in the grid"),
])
def test_bad_sweep_files_are_one_error(tmp_path, text, words):
    with pytest.raises(SweepError) as info:
        plan_sweep(_spec(text, tmp_path))
    assert words in str(info.value)


@pytest.mark.parametrize(("text", "key"), [
    ('[grid]\n"vision.threshold" = [100, 300]\n', "vision.threshold"),
    ('[grid]\nlighting = ["front", "disco"]\n', "lighting"),
    ('[grid]\n"vison.threshold" = [1]\n', "vison"),
    ('[grid]\n"job.gap_mm" = [-1.0]\n', "job.gap_mm"),
    ('[job]\ncodec = "png"\n', "job.codec"),
    ('[scenario]\n"parts.count" = 0\n', "parts.count"),
])
def test_bad_keys_and_values_name_the_key_and_the_file(tmp_path, text, key):
    with pytest.raises((SweepError, ScenarioError)) as info:
        plan_sweep(_spec(text, tmp_path))
    assert key in str(info.value) and "s.toml" in str(info.value)


def test_unreadable_sweep_files_are_one_error(tmp_path):
    with pytest.raises(SweepError, match="no such sweep file"):
        load_sweep(tmp_path / "missing.toml")
    with pytest.raises(SweepError, match="is a directory"):
        load_sweep(tmp_path)
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe\x00junk")
    with pytest.raises(SweepError, match="not UTF-8"):
        load_sweep(tmp_path / "bin.toml")
    (tmp_path / "bad.toml").write_text("[sweep\n")
    with pytest.raises(SweepError, match="not valid TOML"):
        load_sweep(tmp_path / "bad.toml")
    missing_base = write_tiny(tmp_path, '[sweep]\nbase = "nowhere.toml"\n', "b.toml")
    with pytest.raises(ScenarioError, match="nowhere.toml"):
        plan_sweep(load_sweep(missing_base))


def test_every_study_file_plans(tmp_path):
    from tests.sweep.helpers import STUDIES

    names = sorted(p.stem for p in STUDIES.glob("*.toml"))
    assert names == ["compression", "edges", "lighting", "matching", "sampling", "smoothing", "threshold"]
    for path in STUDIES.glob("*.toml"):
        plan = plan_sweep(load_sweep(path))
        assert plan.spec.report == path.stem and len(plan.runs) >= 40, path


@pytest.mark.parametrize("section", ["[grid]", "[[case]]", "[scenario]", "[job]"])
def test_a_key_nested_thousands_deep_is_one_error(tmp_path, section):
    text = f"{section}\n" + "a." * 3000 + "a = [1]\n"
    with pytest.raises(SweepError, match=r"is nested more than 16 tables deep"):
        _spec(text, tmp_path)


def test_editing_the_base_scenario_file_makes_new_run_ids(tmp_path):
    """A resumed sweep must not take runs made with another base scenario for finished
    ones: a key the grid does not name (the belt's speed) changes every run id."""
    text = '[sweep]\nbase = "base.toml"\n' + TINY.split("[sweep]\n", 1)[1]
    (tmp_path / "base.toml").write_text("[conveyor]\nspeed = 0.1\n")
    a = {r.run_id for r in plan_sweep(_spec(text, tmp_path)).runs}
    assert a == {r.run_id for r in plan_sweep(_spec(text, tmp_path)).runs}
    (tmp_path / "base.toml").write_text("[conveyor]\nspeed = 0.2\n")
    b = plan_sweep(_spec(text, tmp_path))
    assert {r.scenario.conveyor.speed for r in b.runs} == {0.2}
    assert len(b.runs) == len(a) and not a & {r.run_id for r in b.runs}


def test_a_case_does_not_inherit_the_keys_another_case_set(tmp_path):
    """Each point starts from the base scenario: the second case (which sets neither
    lighting nor the threshold) keeps the defaults, whatever the first case set."""
    from cell.scenario import Scenario

    text = ('[sweep]\njob = "detect"\n[[case]]\nlighting = "dim"\n"vision.threshold" = [100, 120]\n'
            '[[case]]\n"vision.segmentation" = "otsu"\n')
    runs = plan_sweep(_spec(text, tmp_path)).runs
    default = Scenario()
    assert [(r.scenario.lighting, r.scenario.vision.threshold) for r in runs] == [
        ("dim", 100), ("dim", 120), (default.lighting, default.vision.threshold)]
    assert runs[2].scenario.vision.segmentation == "otsu"
    assert runs[0].scenario.vision.segmentation == default.vision.segmentation


def test_a_case_key_replaces_the_grids_axis_of_that_key(tmp_path):
    """A case that sets ``lighting`` (a grid axis) has one lighting axis, its own: the
    summary lists 'lighting: 1 values', and the run count is not the grid's."""
    spec = _spec(TINY + '\n[[case]]\nlighting = "dim"\n"vision.segmentation" = "belt"\nseeds = [7]\n',
                 tmp_path)
    third = spec.cases[2]
    assert [(a.keys, len(a.values)) for a in third.axes] == [
        (("lighting",), 1), (("vision.segmentation",), 1)]
