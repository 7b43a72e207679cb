"""`cell bench vision --quick`: runs every preset and reports every promised figure."""

from __future__ import annotations

import json

import pytest

from cell.benchmarks.vision import SEED_BASE, cold_start, main, run
from cell.catalogue import LIGHTING_PRESETS


def test_quick_run_reports_each_preset():
    report = run(scenes=1)
    assert report["seed_base"] == SEED_BASE >= 1000  # never a test seed
    assert set(report["presets"]) == set(LIGHTING_PRESETS)
    for preset, r in report["presets"].items():
        assert r["parts"] > 0, preset
        for key in ("material_accuracy", "kind_accuracy", "position_p50_mm", "position_p95_mm",
                    "yaw_p95_deg", "false", "missed", "latency_ms", "latency_over_render"):
            assert key in r
        assert r["latency_ms"] > 0 and r["render_ms"] > 0 and r["repeat_latency_ms"] > 0
        assert r["latency_p95_ms"] >= r["latency_ms"]
        assert 0.0 <= r["material_accuracy"] <= 1.0
        assert 0.0 <= r["recall"] <= 1.0
        steps = r["step_ms"]  # where the time goes: the medians of each step
        assert list(steps) == ["foreground", "outlines", "parts", "material", "pose"]
        assert all(v >= 0 for v in steps.values()) and steps["foreground"] > 0
        assert sum(steps.values()) <= 1.5 * r["latency_p95_ms"]
    assert report["presets"]["back"]["material_wrong"] == 0


def test_cli_json(capsys):
    assert main(["--scenes", "1", "--json"]) == 0
    assert "presets" in json.loads(capsys.readouterr().out)


def test_pick_zone_frames_with_fewer_parts():
    report = run(scenes=1, parts=2)
    assert report["parts_per_scene"] == 2
    for preset, r in report["presets"].items():
        assert 0 < r["parts"] + r["missed"] + r["partial_ok"] + r["partial_wrong"] <= 2, preset
        assert r["latency_ms"] > 0


def test_cli_rejects_a_bad_part_count():
    import pytest

    with pytest.raises(SystemExit):
        main(["--scenes", "1", "--parts", "0"])


def test_a_subset_of_presets(capsys):
    import pytest

    report = run(scenes=1, presets=["dim", "front"])
    assert list(report["presets"]) == ["front", "dim"]  # (the catalogue's order)
    from cell.errors import BenchError

    with pytest.raises(BenchError, match="valid: front, back"):
        run(scenes=1, presets=["bright"])
    with pytest.raises(SystemExit):
        main(["--presets", "dim,bright"])
    assert "unknown bright" in capsys.readouterr().err


def test_cold_start_times_a_fresh_process():
    cold = cold_start()
    assert cold["detections"] > 0
    assert 0 < cold["detect_s"] <= cold["first_detection_s"] < cold["process_s"]


def test_latency_per_part_divides_by_the_parts_in_view_not_the_background():
    r = run(scenes=1, parts=1, presets=["front"])["presets"]["front"]
    assert r["parts"] + r["missed"] + r["partial_ok"] + r["partial_wrong"] == 1  # the one part is in view
    assert r["latency_per_part_ms"] == pytest.approx(r["latency_ms"])


def _report(**changes):
    row = {"material_accuracy": 1.0, "material_wrong": 0, "kind_accuracy": 1.0,
           "position_p95_mm": 0.4, "yaw_p95_deg": 0.9, "latency_ms": 4.0,
           "latency_over_render": 0.3}
    presets = {"front": dict(row), "back": dict(row, material_accuracy=0.0)}
    for key, value in changes.items():
        preset, field = key.split("__")
        presets[preset][field] = value
    return {"presets": presets}


def test_the_verdict_names_each_bar_missed():
    from cell.benchmarks.vision_score import failures

    assert failures(_report()) == []  # (back's material is unknown: allowed)
    assert failures(_report(front__latency_ms=33.8, back__latency_over_render=1.56)) == [
        "front latency_ms 33.8 > 5", "back latency_over_render 1.56 > 0.5"]
    assert failures(_report(front__material_accuracy=0.99, front__kind_accuracy=None)) == [
        "front material_accuracy 0.99 < 0.995", "front kind_accuracy: no figure"]
    assert failures(_report(back__material_wrong=2, front__yaw_p95_deg=2.5,
                            front__position_p95_mm=1.2)) == [
        "front position_p95_mm 1.2 > 1", "front yaw_p95_deg 2.5 > 2",
        "back material_wrong 2 > 0"]
    slow = dict(_report(), cold={"first_detection_s": 6.2})
    assert failures(slow) == ["cold first_detection_s 6.2 > 5"]


def test_the_report_carries_its_verdict(capsys):
    from cell.benchmarks.vision import _print
    from cell.benchmarks.vision_score import failures

    report = run(scenes=1, presets=["front"])
    assert report["failures"] == failures(report)
    assert report["meets_required"] == (not report["failures"])
    _print(report)
    last = capsys.readouterr().out.splitlines()[-1]
    if report["meets_required"]:
        assert last == "required: met"
    else:
        assert last == f"required: NOT met ({len(report['failures'])}: " \
            f"{'; '.join(report['failures'])})"
