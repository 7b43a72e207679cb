"""Study reports on grids that lack what a headline compares against: they say so, rather
than reading a missing reference as a failure (rows made by hand, no runs)."""

from __future__ import annotations

import pytest

from cell.sweep.reports import compression, generic, lighting, matching
from cell.sweep.reports.threshold import band


def _jpeg(quality: int) -> dict:
    return {"job": "compress", "job.codec": "jpeg", "job.quality": quality, "job.chroma": "420",
            "bytes": 20e3, "ratio": 45.0, "psnr_db": 40.0, "recall": 1.0,
            "classification_accuracy": 1.0, "position_error_mm_mean": 0.14}


def test_compression_without_a_lossless_run_judges_no_jpeg():
    heads = compression.build([_jpeg(90), _jpeg(50)], None).headlines
    assert any("no lossless run" in h for h in heads)
    assert not any("loses detector accuracy" in h or "keeps the detector" in h for h in heads)


def test_matching_without_the_unchanged_frame_says_so():
    row = {"job": "match", "job.method": "ncc", "job.brightness": 40.0, "job.contrast": 1.0,
           "job.rotation_deg": 0.0, "hit_rate": 1.0, "peak_error_px_median": 0.0, "match_ms": 3.0}
    heads = matching.build([row], None).headlines
    assert heads == ("ncc: no run on the unchanged frame in this grid (brightness +0, contrast x1, "
                     "no turn), which its ranges are measured from",)


def test_lighting_with_every_part_found_under_every_light_ranks_none():
    rows = [{"job": "detect", "lighting": li, "recall": 1.0, "kind_accuracy": 1.0,
             "material_accuracy": acc, "material_unknown": unknown, "position_error_mm_mean": 0.1}
            for li, acc, unknown in (("front", 1.0, 0.0), ("back", 0.0, 1.0))]
    report = lighting.build(rows, None)
    assert report.headlines[0] == "detector: the same share of parts found under every light (100%)"
    assert "| back | 100% | 100% | unknown |" in report.tables[0]  # as the plot says (was 0%)


def test_the_generic_report_leads_with_a_metric_that_changes():
    rows = [{"lighting": li, "parts": 6, "found": found} for li, found in (("front", 6), ("dim", 4))]
    report = generic.overview(rows, ("lighting",), ("parts", "found"))
    assert report.headlines[0].startswith("found: highest 6 at lighting=front; lowest 4")


def test_the_generic_plot_puts_each_point_under_its_own_label(monkeypatch):
    """Lines over a text axis share its positions: otsu's "front" and "raking" points were
    drawn under belt's "raking" and "dim" labels (each line counted its own values)."""
    figures = []
    monkeypatch.setattr(generic, "png", lambda fig: figures.append(fig) or b"")
    rows = [{"lighting": li, "vision.segmentation": seg, "found": n}
            for li, seg, n in (("front", "otsu", 4), ("raking", "otsu", 5),
                               ("raking", "belt", 6), ("dim", "belt", 7))]
    generic.overview(rows, ("lighting", "vision.segmentation"), ("found",))
    ax = figures[0].axes[0]
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    drawn = {line.get_label(): {ticks[int(x)]: y for x, y in zip(*line.get_data(), strict=True)}
             for line in ax.get_lines()}
    assert drawn == {"vision.segmentation=otsu": {"front": 4, "raking": 5},
                     "vision.segmentation=belt": {"raking": 6, "dim": 7}}


def test_threshold_calls_a_method_that_finds_the_same_everywhere_so():
    from cell.sweep.reports import threshold

    rows = [{"job": "detect", "lighting": li, "vision.segmentation": "belt", "recall": 1.0,
             "fg_iou": 0.9} for li in ("front", "back")]
    heads = threshold.build(rows, None).headlines
    assert "belt: finds 100% of the parts under each of the 2 presets" in heads
    assert not any("worst under" in h for h in heads)


def test_edges_on_one_setting_names_no_too_low_or_too_high():
    from cell.sweep.reports import edges

    row = {"job": "edges", "lighting": "front", "job.high": 100.0, "job.low_ratio": 0.4,
           "outline_closed": 0.9, "clutter": 0.05}
    heads = edges.build([row], None).headlines
    assert not any("too low" in h for h in heads), heads


def test_a_report_leaves_the_callers_matplotlib_backend_alone():
    # (it called matplotlib.use("Agg"): a notebook's inline plots stopped showing)
    import subprocess
    import sys

    code = ("import matplotlib; matplotlib.use('svg'); import matplotlib.pyplot as plt; "
            "f = plt.figure(); from cell.sweep.reports import lighting; "
            "rows = [{'job': 'detect', 'lighting': 'front', 'recall': 1.0, 'kind_accuracy': 1.0, "
            "'material_accuracy': 1.0, 'material_unknown': 0.0, 'position_error_mm_mean': 0.1}]; "
            "r = lighting.build(rows, None); assert r.plots and r.plots[0].png[:4] == b'\\x89PNG'; "
            "print(matplotlib.get_backend(), plt.get_fignums())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["svg", "[1]"]


def test_threshold_without_a_detect_run_still_reports_the_sort_runs():
    """Twelve finished sort runs came out as 'No detect run finished.' alone."""
    from cell.sweep.reports import threshold

    rows = [{"job": "sort", "lighting": "front", "vision.segmentation": "otsu",
             "vision.threshold": 150.0, "sort_accuracy": 0.75, "classification_accuracy": 1.0,
             "rejected": 1.0, "missed": 0.0}]
    report = threshold.build(rows, None)
    assert report.headlines == ("No detect run finished.",
                                "sort job, front, otsu: sort accuracy 75%")
    assert "| front | otsu | 75% | 100% | 1.0 | 0.0 |" in report.tables[0]


def test_the_smoothing_plot_names_the_line_styles_as_drawn(monkeypatch):
    """Styles follow the file's order of filters, the kernel its size: the label said
    'solid: Gaussian 3x3, dashed: median 3x3' whatever the order and size."""
    from cell.sweep.reports import smoothing

    figures = []
    monkeypatch.setattr(smoothing, "png", lambda fig: figures.append(fig) or b"")
    rows = [{"job": "smooth", "job.filter": f, "job.iterations": n, "job.ksize": 5,
             "sensor.noise_std": 10.0, "sensor.salt_pepper": 0.0, "fg_iou": 0.9,
             "position_error_mm_mean": 0.1} for f in ("median", "gaussian") for n in (0, 1)]
    smoothing.build(rows, None)
    assert figures[0].axes[0].get_xlabel() == "filter passes (solid: median 5x5, dashed: gaussian 5x5)"


@pytest.mark.parametrize(("recalls", "expected"), [
    ([0.95, 1.0, 0.92, 0.5, 0.95], (0, 2)),    # reaches the first threshold; stops at the dip
    ([0.3, 0.85, 1.0, 0.91, 0.89], (2, 3)),    # 90 % of the best, not less
    ([None, 0.0, 0.6, None], (2, 2)),
    ([None, 0.0], None),                       # nothing found anywhere
])
def test_the_band_is_the_run_around_the_best_recall_within_90_percent(recalls, expected):
    assert band(recalls) == expected


def test_lighting_names_the_best_and_worst_light_for_parts_found_and_position():
    rows = [{"job": "detect", "lighting": li, "recall": recall, "kind_accuracy": 1.0,
             "material_accuracy": 1.0, "material_unknown": 0.0, "position_error_mm_mean": err}
            for li, recall, err in (("front", 0.9, 0.30), ("dim", 0.5, 0.80), ("raking", 1.0, 0.12))]
    heads = lighting.build(rows, None).headlines
    assert "detector: most parts found under raking (100%), fewest under dim (50%)" in heads
    assert ("detector position: most precise under raking (0.12 mm mean), least under dim "
            "(0.80 mm)") in heads


def _jpeg_at(quality: int, classification: float = 1.0, position: float = 0.10) -> dict:
    return {"job": "compress", "job.codec": "jpeg", "job.quality": quality, "job.chroma": "420",
            "bytes": 20e3, "ratio": 45.0, "psnr_db": 40.0, "recall": 1.0,
            "classification_accuracy": classification, "position_error_mm_mean": position}


def _keeps_from(rows: list[dict]) -> str:
    from cell.sweep.reports import compression

    lossless = {**_jpeg_at(0), "job.codec": "png", "job.quality": None, "job.chroma": None, "ratio": 3.0}
    heads = compression.build([lossless, *rows], None).headlines
    return next(h for h in heads if h.startswith("JPEG 420"))


def test_compression_keeps_within_2_points_and_005_mm_from_the_lowest_quality_every_higher_keeps():
    assert "from quality 70 up" in _keeps_from(  # 0.20 mm at 50 is 0.10 mm off lossless
        [_jpeg_at(50, position=0.20), _jpeg_at(70, position=0.13), _jpeg_at(90)])
    assert "from quality 70 up" in _keeps_from(  # 95 % at 50 is 5 points off lossless
        [_jpeg_at(50, classification=0.95), _jpeg_at(70, classification=0.99), _jpeg_at(90)])
    assert "from quality 70 up" in _keeps_from(  # 30 keeps, 50 does not: from 70
        [_jpeg_at(30), _jpeg_at(50, position=0.5), _jpeg_at(70), _jpeg_at(90)])
    assert "loses detector accuracy even at quality 90" in _keeps_from(
        [_jpeg_at(70), _jpeg_at(90, position=0.3)])


def test_matching_ranges_end_at_the_first_step_under_90_percent_hits():
    from cell.sweep.reports import matching

    def row(brightness: float, hits: float, method: str = "ncc") -> dict:
        return {"job": "match", "job.method": method, "job.brightness": brightness,
                "job.contrast": 1.0, "job.rotation_deg": 0.0, "hit_rate": hits,
                "peak_error_px_median": 0.5, "match_ms": 3.0}

    rows = [row(0.0, 1.0), row(-40.0, 0.95), row(-80.0, 0.6), row(-120.0, 0.95),
            row(40.0, 1.0), row(80.0, 0.8)]
    heads = matching.build(rows, None).headlines
    assert heads == ("ncc: 100% hits on the unchanged frame (peak error 0.50 px); >= 90 % hits for "
                     "brightness -40 to +40, contrast x1 to x1 and turns up to 0 deg; at a 0 deg "
                     "turn 100%",)


def test_the_generic_report_leaves_out_parameters_that_never_change():
    """A fixed key (2 parts in every run) is no axis: not the plot's x, not in the headline
    or the table (it was the x axis, a numeric column before the varying light)."""
    from cell.sweep.reports import generic

    rows = [{"parts.count": 2, "lighting": li, "found": found} for li, found in (("front", 6), ("dim", 4))]
    assert generic.varying(rows, ("parts.count", "lighting")) == ["lighting"]
    report = generic.overview(rows, ("parts.count", "lighting"), ("found",))
    assert report.headlines == ("found: highest 6 at lighting=front; lowest 4 at lighting=dim "
                                "(mean over seeds).",)
    assert "parts.count" not in report.tables[0]


def test_summary_lists_ten_failed_runs_and_counts_the_rest(tmp_path):
    import tomllib

    from cell.sweep.plan import plan_sweep
    from cell.sweep.reports.summary import summary_text
    from cell.sweep.reports.table import Report
    from cell.sweep.spec import sweep_from_dict
    from tests.sweep.helpers import TINY

    plan = plan_sweep(sweep_from_dict(tomllib.loads(TINY), source=str(tmp_path / "s.toml"),
                                      folder=tmp_path))
    rows = [{"run_id": r.run_id, "seed": r.scenario.seed, "lighting": r.scenario.lighting,
             "error": f"boom {i}" if i < 11 else None} for i, r in enumerate(plan.runs)]
    text = summary_text(plan, rows, Report(("a finding",), (), ()))
    assert "- runs: 12 of 12 in `results.csv` (11 failed: see below)" in text
    failed = text.split("## Runs that failed", 1)[1]
    assert failed.count("): boom ") == 10 and "boom 10" not in failed
    assert "- ... and 1 more (the `error` column of `results.csv`)" in failed
    assert f"(seed {plan.runs[0].scenario.seed}, lighting = 'front'" in failed
