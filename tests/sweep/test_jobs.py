"""The jobs a run can do, on small rendered scenes: each measures what it says, against the
scene's ground truth, and the same scenario gives the same figures."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from cell.catalogue import KINDS
from cell.errors import ScenarioError
from cell.scenario import scenario_from_dict
from cell.sweep.errors import SweepError
from cell.sweep.jobs import compress, detect, edges, match, smooth, sort
from cell.sweep.scene import place_parts


def _scenario(**sections):
    # two parts: the sort test's calibration set-up is then the tiny studies' (one calibration)
    return scenario_from_dict({"seed": 4, "parts": {"count": 2}, **sections})


@pytest.fixture(scope="module")
def scene():
    return detect.prepare(_scenario(), detect.Settings())


def test_the_scene_is_the_scenarios_alone_and_fails_clearly_when_parts_do_not_fit(scene):
    again = detect.prepare(_scenario(vision={"segmentation": "otsu"}), detect.Settings())
    assert [p.position for p in again.parts] == [p.position for p in scene.parts]
    assert np.array_equal(again.image, scene.image)
    assert detect.scene_key(_scenario(), detect.Settings()) == \
        detect.scene_key(_scenario(vision={"threshold": 10}), detect.Settings())
    assert detect.scene_key(_scenario(), detect.Settings()) != \
        detect.scene_key(_scenario(lighting="back"), detect.Settings())
    crowded = scenario_from_dict({"seed": 1, "parts": {"count": 40}})
    with pytest.raises(SweepError, match="cannot lay out 40 parts"):
        detect.prepare(crowded, detect.Settings())


def test_detect_finds_names_and_places_the_parts(scene):
    out = detect.measure(scene, _scenario(), detect.Settings())
    assert out["parts"] == 2 and out["recall"] == 1.0
    assert out["false_detections"] <= 1  # (the detector now and then takes a piece of the belt's edge)
    assert out["kind_accuracy"] == 1.0 and out["material_accuracy"] == 1.0
    assert out["position_error_mm_max"] < 1.0 and out["fg_iou"] > 0.9
    fixed = detect.measure(scene, _scenario(vision={"segmentation": "fixed", "threshold": 250}),
                           detect.Settings())
    assert fixed["recall"] == 0.0 and fixed["kind_accuracy"] is None  # no samples: None, never NaN


def test_back_and_front_combined_lends_the_material_to_the_silhouettes():
    back = _scenario(lighting="back")
    both = _scenario(lighting="back", capture={"presets": ["back", "front"]})
    alone = detect.measure(detect.prepare(back, detect.Settings()), back, detect.Settings())
    combined = detect.measure(detect.prepare(both, detect.Settings()), both, detect.Settings())
    assert alone["recall"] == combined["recall"] == 1.0
    assert alone["material_unknown"] == 1.0 and combined["material_accuracy"] == 1.0


def test_lossless_codecs_change_nothing_and_jpeg_is_smaller(scene):
    png = compress.measure(scene, _scenario(), compress.Settings(codec="png"))
    rle = compress.measure(scene, _scenario(), compress.Settings(codec="rle"))
    jpeg = compress.measure(scene, _scenario(), compress.Settings(codec="jpeg", quality=50))
    ref = detect.measure(scene, _scenario(), detect.Settings())
    for out in (png, rle):
        assert out["psnr_db"] is None
        assert out["position_error_mm_mean"] == ref["position_error_mm_mean"]
    assert jpeg["bytes"] < png["bytes"] < rle["bytes"] and jpeg["psnr_db"] > 20
    assert rle["mask_ratio"] > 10 and rle["mask_rle_bytes"] < rle["mask_raw_bytes"]
    data = compress.encode(scene.image, compress.Settings(codec="rle"))
    assert np.array_equal(compress.decode(data, compress.Settings(codec="rle")), scene.image)


def test_smoothing_nothing_is_the_detector_alone(scene):
    out = smooth.measure(scene, _scenario(), smooth.Settings(filter="none"))
    ref = detect.measure(scene, _scenario(), detect.Settings())
    assert out["fg_iou"] == ref["fg_iou"] and out["recall"] == ref["recall"]
    image = smooth.smooth(scene.image, smooth.Settings(filter="median", iterations=2))
    assert image.shape == scene.image.shape and not np.array_equal(image, scene.image)


def test_matching_finds_the_templates_and_ncc_shrugs_off_brightness():
    scenario = _scenario()
    scene2 = match.prepare(scenario, match.Settings())
    assert len(scene2.retakes) == 1 and not np.array_equal(scene2.retakes[0], scene2.image)
    plain = match.measure(scene2, scenario, match.Settings(method="ncc"))
    assert plain["templates"] == 2 and plain["hit_rate"] == 1.0 and plain["peak_error_px_median"] <= 1
    bright_ssd = match.measure(scene2, scenario, match.Settings(method="ssd", brightness=80))
    bright_ncc = match.measure(scene2, scenario, match.Settings(method="ncc", brightness=80))
    assert bright_ncc["hit_rate"] == 1.0 and bright_ssd["hit_rate"] < 1.0


def test_an_outline_closes_only_without_a_gap_wider_than_the_bridge():
    import cv2

    ring = np.zeros((60, 60), np.uint8)
    cv2.circle(ring, (30, 30), 20, 255, 1)
    part = np.zeros((60, 60), np.uint8)
    cv2.circle(part, (30, 30), 20, 255, -1)
    assert edges.closed_outline(ring > 0, part > 0, max_gap=1)
    ring[8:14, :] = 0  # a gap of 6 px at the top
    assert not edges.closed_outline(ring > 0, part > 0, max_gap=1)


def test_edges_scores_canny_against_the_outlines(scene):
    low = edges.measure(scene, _scenario(), edges.Settings(high=100))
    high = edges.measure(scene, _scenario(), edges.Settings(high=5000))
    assert low["parts"] == 2 and low["outline_recall"] > 0.5 and low["edge_pixels"] > 0
    assert high["edge_pixels"] == 0 and high["outline_closed"] == 0.0 and high["clutter"] is None


def test_sort_runs_the_closed_loop_calibrating_once_per_set_up():
    scenario = _scenario()
    first = sort.measure(None, scenario, sort.Settings())
    second = sort.measure(None, scenario, sort.Settings())
    for out in (first, second):
        assert out["spawned"] == 2
        assert out["spawned"] == out["binned"] + out["rejected"] + out["missed"] + out["dropped"]
        assert 0.0 <= out["sort_accuracy"] <= 1.0
    assert second["calibration_s"] == 0.0  # the worker's calibration was reused
    assert {k: v for k, v in first.items() if k not in sort.TIMINGS} == \
        {k: v for k, v in second.items() if k not in sort.TIMINGS}
    other = sort.calibration_scenario(_scenario(lighting="back", vision={"threshold": 10}), sort.Settings())
    assert other == sort.calibration_scenario(scenario, sort.Settings())


SCENARIO = {"seed": 4, "parts": {"count": 2}}  # the module's scene


def test_compress_reports_the_raw_frame_over_the_bytes_and_444_costs_more_than_420(scene):
    scenario = scenario_from_dict(SCENARIO)
    s420 = compress.measure(scene, scenario, compress.Settings(codec="jpeg", quality=50, chroma="420"))
    s444 = compress.measure(scene, scenario, compress.Settings(codec="jpeg", quality=50, chroma="444"))
    h, w, _ = scene.image.shape
    assert s420["ratio"] == pytest.approx(h * w * 3 / s420["bytes"]) and s420["ratio"] > 1
    assert s420["bits_per_pixel"] == pytest.approx(8 * s420["bytes"] / (h * w))
    # full-resolution colour keeps more: more bytes and a better PSNR at the same quality
    assert s444["bytes"] > s420["bytes"] and s444["psnr_db"] > s420["psnr_db"], (s420, s444)


def test_smoothing_applies_every_median_pass_and_refuses_an_even_kernel(scene):
    once = smooth.smooth(scene.image, smooth.Settings(filter="median", iterations=1))
    thrice = smooth.smooth(scene.image, smooth.Settings(filter="median", iterations=3))
    again = smooth.smooth(smooth.smooth(once, smooth.Settings(filter="median", iterations=1)),
                          smooth.Settings(filter="median", iterations=1))
    assert not np.array_equal(once, thrice) and np.array_equal(thrice, again)
    with pytest.raises(ScenarioError, match="'job.ksize' must be odd, got 4"):
        smooth.Settings(ksize=4)


def test_match_median_over_every_part_counts_the_misses():
    scenario = scenario_from_dict(SCENARIO)
    scene2 = match.prepare(scenario, match.Settings())
    out = match.measure(scene2, scenario, match.Settings(method="ssd", brightness=80))
    assert out["templates"] == 2 and out["hit_rate"] == 0.5  # one hit, one miss
    assert out["peak_error_px_median"] <= 3.0
    assert out["peak_error_px_median_all"] > 3.0, out  # the miss pulls the median of both past hit_px


def test_edges_low_threshold_tolerance_and_clutter(scene):
    scenario = scenario_from_dict(SCENARIO)
    strict = edges.measure(scene, scenario, edges.Settings(high=100, low_ratio=0.4, tolerance_px=0.0))
    loose = edges.measure(scene, scenario, edges.Settings(high=100, low_ratio=0.4, tolerance_px=2.0))
    assert strict["low"] == loose["low"] == pytest.approx(40.0)  # low_ratio * high
    assert strict["edge_pixels"] == loose["edge_pixels"]  # the tolerance scores, it does not detect
    assert strict["outline_recall"] < loose["outline_recall"] == 1.0
    assert loose["clutter"] <= strict["clutter"] < 0.2  # clean rendered parts: little clutter


def test_scene_places_parts_at_least_gap_apart():
    scenario = scenario_from_dict({"seed": 1, "parts": {"count": 4}})
    kinds = ["washer", "hex_nut", "disc", "square_nut"]
    gap = 0.03
    places = place_parts(kinds, scenario, np.random.default_rng(0), gap=gap)
    assert len(places) == 4
    for (a, ka), (b, kb) in itertools.combinations(zip(places, kinds, strict=True), 2):
        least = KINDS[ka].half_diagonal + KINDS[kb].half_diagonal + gap
        assert math.hypot(a[0] - b[0], a[1] - b[1]) >= least - 1e-12


def test_sort_calibrates_with_the_jobs_calibration_seed_and_lighting():
    scenario = scenario_from_dict(SCENARIO)
    cal = sort.calibration_scenario(scenario, sort.Settings(calibration_seed=9, calibration_lighting="back"))
    assert (cal.seed, cal.lighting) == (9, "back") and scenario.seed == 4


def test_a_users_detector_gets_no_foreground_iou(scene):
    from tests.sweep import slow_detector  # our detector behind a user's name (not slowed here)

    ours = detect.measure(scene, scenario_from_dict(SCENARIO), detect.Settings())
    user_scenario = scenario_from_dict({**SCENARIO, "vision": {"detector": slow_detector.NAME}})
    users = detect.measure(scene, user_scenario, detect.Settings())
    assert ours["fg_iou"] > 0.9 and users["fg_iou"] is None  # its foreground is not ours to score
    assert users["recall"] == ours["recall"]
