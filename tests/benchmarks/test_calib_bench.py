"""``cell bench calib``: a quick run is strict JSON with both cameras and every figure."""

from __future__ import annotations

import json

import pytest

from cell.benchmarks import BENCHMARKS, calib


def _strict_json(text: str) -> dict:
    def reject(name: str):
        raise AssertionError(f"{name} in the JSON output")

    return json.loads(text, parse_constant=reject)


def test_a_quick_run_reports_both_cameras_in_strict_json(capsys):
    assert BENCHMARKS["calib"] == "cell.benchmarks.calib"
    assert calib.main(["--quick", "--json", "--setups", "distortion", "--poses", "5"]) == 0
    data = _strict_json(capsys.readouterr().out)
    assert data["seeds"] == 1 and data["poses"] == 5 and data["seed_base"] >= 1000
    assert data["required"] == {"focal_rel_err": 0.002, "reproj_rms_px": 0.3, "hand_eye_rot_deg": 0.05,
                                "hand_eye_trans_mm": 0.5, "touch_err_mm": 1.0, "k1_rel_err": 0.05}
    assert list(data["setups"]) == ["distortion"]
    cameras = data["setups"]["distortion"]["cameras"]
    assert list(cameras) == ["wrist", "overhead"]
    methods = {"wrist": {"TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS", "refined"},
               "overhead": {"SHAH", "LI", "refined"}}
    for name, c in cameras.items():
        s = c["summary"]
        for figure in ("focal_rel_err", "reproj_rms_px", "hand_eye_rot_deg", "hand_eye_trans_mm",
                       "touch_err_mm", "k1_rel_err", "wall_s"):
            assert s[figure]["median"] is not None and s[figure]["worst"] >= s[figure]["median"], figure
        assert set(s["methods"]) == methods[name]
        assert s["k1_rel_err"]["worst"] < 0.2  # the lens's k1 = -0.2 is found
        assert isinstance(s["meets_required"], bool) and isinstance(s["failures"], list)
        run = c["runs"][0]
        assert run["seed"] == data["seed_base"] and run["views_used"] >= 3


def test_the_table_names_the_bars(capsys):
    report = {"seeds": 1, "seed_base": 1000, "poses": 20, "overrides": [], "required": calib.REQUIRED,
              "meets_required": False, "wall_s": 1.0, "setups": {"default": {"cameras": {"overhead": {
                  "summary": {**{k: {"median": None, "worst": None} for k in calib._FIGURES},
                              "methods": {}, "kept": ["SHAH"], "failures": ["touch_err_mm: 2 > 1"],
                              "meets_required": False}}}}}}
    calib._print(report)
    out = capsys.readouterr().out
    assert "NOT met" in out and "default overhead: touch_err_mm: 2 > 1" in out and "nan" not in out.lower()


def test_every_seed_of_every_set_up_calibrates_every_camera(monkeypatch):
    """The bench's bookkeeping, on stand-in reports: each set-up runs each seed with the
    camera asked for, and the summary's median and worst are over the seeds."""
    import cell.calib.job as job

    calls = []

    def fake(scenario, *, camera):
        calls.append((scenario.seed, camera, scenario.calibration.joint_noise_deg,
                      scenario.sensor.distortion[0], scenario.calibration.poses))
        names = ("wrist", "overhead") if camera == "all" else (camera,)
        err = 0.001 * (scenario.seed - 1000 + 1)
        k = {"fx_rel_err": err, "fy_rel_err": -2 * err, "cx_err_px": 0.1, "cy_err_px": 0.1,
             "k1_rel_err": None if scenario.sensor.distortion[0] == 0 else err, "reproj_rms_px": 0.04,
             "views_used": 20}
        cams = {n: {"intrinsics": k, "intrinsics_held": "calibrateCamera", "touch_err_mm": 0.1, "wall_s": 1.0,
                    "hand_eye": {"SHAH": {"rot_err_deg": err, "trans_err_mm": 0.1},
                                 "refined": {"rot_err_deg": err, "trans_err_mm": 0.1},
                                 "chosen": "SHAH", "kept": "SHAH"}} for n in names}

        class Run:
            report = {"cameras": cams}
        return Run()

    monkeypatch.setattr(job, "run_calibration", fake)
    out = calib.run(seeds=2, seed_base=1000, poses=7)
    assert len(calls) == 6 and {c[1] for c in calls} == {"all"} and {c[4] for c in calls} == {7}
    assert {(c[2], c[3]) for c in calls} == {(0.0, 0.0), (0.0, -0.2), (0.01, 0.0)}
    for name, setup in out["setups"].items():
        assert list(setup["cameras"]) == ["wrist", "overhead"]
        for c in setup["cameras"].values():
            assert [r["seed"] for r in c["runs"]] == [1000, 1001]
            assert c["summary"]["focal_rel_err"]["worst"] == 0.004  # max(|fx|, |fy|) of the worse seed
            assert c["summary"]["hand_eye_rot_deg"]["median"] == 0.0015
            assert (c["summary"]["k1_rel_err"]["worst"] is None) == (name != "distortion")
    assert out["meets_required"] is False  # focal 0.4 % > 0.2 %
    calls.clear()
    calib.run(seeds=1, seed_base=1000, poses=7, setups=["default"], camera="overhead")
    assert [c[1] for c in calls] == ["overhead"]


@pytest.mark.parametrize(("setting", "owner"), [
    ("seed=5", "--seed-base"), ("calibration.poses=12", "--poses"),
    ("sensor.distortion=[-0.3, 0.1, 0, 0, 0]", "the set-up 'distortion'"),
])
def test_a_set_key_the_bench_sets_itself_is_refused(capsys, setting, owner):
    # (it was overridden without a word: two seeds of one run, 4 poses for 12)
    with pytest.raises(SystemExit) as info:
        calib.main(["--quick", "--set", setting])
    assert info.value.code == 2
    assert f"is set by {owner} in this benchmark" in capsys.readouterr().err


def _good_row(**figures) -> dict:
    """One seed's figures, all within the bars, changed by ``figures``."""
    row = {"focal_rel_err": 0.0005, "reproj_rms_px": 0.05, "hand_eye_rot_deg": 0.01,
           "hand_eye_trans_mm": 0.1, "touch_err_mm": 0.2, "k1_rel_err": 0.01, "wall_s": 1.0,
           "methods": {"SHAH": {"rot_deg": 0.01, "trans_mm": 0.1}}, "kept": "SHAH"}
    return {**row, **figures}


def test_k1_is_held_to_its_bar_only_when_the_lens_distorts():
    rows = [_good_row(), _good_row(k1_rel_err=0.08)]
    distorted = calib._summary(rows, distorted=True)
    assert distorted["meets_required"] is False
    assert distorted["failures"] == ["k1_rel_err 0.08 > 0.05"]
    assert calib._summary(rows, distorted=False)["meets_required"] is True
    no_k1 = calib._summary([_good_row(k1_rel_err=None)], distorted=True)
    assert no_k1["failures"] == ["k1_rel_err: no figure"]


def test_one_failing_set_up_fails_the_whole_bench(monkeypatch):
    """The verdict is every set-up's, every camera's: the distortion set-up alone
    missing the focal bar makes ``meets_required`` false."""
    import cell.calib.job as job

    def fake(scenario, *, camera):
        err = 0.01 if scenario.sensor.distortion[0] else 0.0005  # 1 % > 0.2 % with distortion only
        k = {"fx_rel_err": err, "fy_rel_err": err, "k1_rel_err": 0.01, "reproj_rms_px": 0.05,
             "views_used": 20}
        cams = {n: {"intrinsics": k, "intrinsics_held": "calibrateCamera", "touch_err_mm": 0.1,
                    "wall_s": 1.0, "hand_eye": {"SHAH": {"rot_err_deg": 0.01, "trans_err_mm": 0.1},
                                                "chosen": "SHAH", "kept": "SHAH"}}
                for n in ("wrist", "overhead")}

        class Run:
            report = {"cameras": cams}
        return Run()

    monkeypatch.setattr(job, "run_calibration", fake)
    out = calib.run(seeds=1, seed_base=1000, poses=7)
    verdicts = {name: [c["summary"]["meets_required"] for c in s["cameras"].values()]
                for name, s in out["setups"].items()}
    assert verdicts == {"default": [True, True], "distortion": [False, False],
                        "joint_noise": [True, True]}
    assert out["meets_required"] is False


def test_the_focal_error_is_that_of_the_intrinsics_the_file_holds():
    """When the file holds the refined intrinsics, their error is the one scored."""
    first = {"fx_rel_err": 0.01, "fy_rel_err": 0.01, "k1_rel_err": 0.1, "reproj_rms_px": 0.05,
             "views_used": 20}
    refined = {"fx_rel_err": 0.0004, "fy_rel_err": -0.0006, "k1_rel_err": -0.02}
    report = {"intrinsics": first, "intrinsics_refined": refined, "intrinsics_held": "refined",
              "touch_err_mm": 0.1, "wall_s": 1.0,
              "hand_eye": {"SHAH": {"rot_err_deg": 0.01, "trans_err_mm": 0.1},
                           "chosen": "SHAH", "kept": "SHAH"}}
    row = calib._row(report)
    assert row["focal_rel_err"] == 0.0006 and row["k1_rel_err"] == 0.02
    assert row["reproj_rms_px"] == 0.05 and row["intrinsics_held"] == "refined"
    held_first = calib._row({**report, "intrinsics_held": "calibrateCamera"})
    assert held_first["focal_rel_err"] == 0.01 and held_first["k1_rel_err"] == 0.1
