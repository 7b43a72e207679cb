"""A small simulated calibration of the wrist camera, end to end, and `cell calibrate`."""

from __future__ import annotations

import json
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from cell.calib import capture
from cell.calib.calfile import CalibrationFile, CameraCalibration, load_calibration, write_calibration
from cell.calib.job import run_calibration
from cell.calib.wrist import MODEL_RATIO, keep_refinement
from cell.cli import main as cell_main
from cell.errors import CalibrationError
from cell.scenario import scenario_from_dict

SEED = 7  # the benchmark figures use seeds >= 1000


@pytest.fixture(scope="module")
def run():
    scenario = scenario_from_dict({"seed": SEED, "calibration": {"poses": 8}})
    return run_calibration(scenario)


def test_a_small_pose_set_recovers_the_camera(run):
    rep = run.report["cameras"]["wrist"]
    i, h = rep["intrinsics"], rep["hand_eye"]
    assert abs(i["fx_rel_err"]) < 0.01 and abs(i["fy_rel_err"]) < 0.01
    assert abs(i["cx_err_px"]) < 3 and abs(i["cy_err_px"]) < 3
    assert i["views_used"] + i["views_rejected"] == 8 and i["views_used"] >= 6
    assert i["reproj_rms_px"] < 0.3
    kept = h[h["kept"]]
    assert kept["rot_err_deg"] < 0.5 and kept["trans_err_mm"] < 5
    for method in ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS", "refined"):
        assert h[method]["rot_err_deg"] < 0.5 and h[method]["trans_err_mm"] < 5
    assert rep["touch_err_mm"] < 2.0 and len(rep["touch"]["errors_mm"]) == 3


def test_the_report_is_strict_json_and_the_camera_loads(run, tmp_path):
    text = json.dumps(run.report, allow_nan=False)
    assert json.loads(text)["cameras"]["wrist"]["intrinsics"]["k1_rel_err"] is None  # true k1 is 0
    cam = run.calibration.camera("wrist")
    assert cam.pose_name == "T_flange_camera" and cam.seed == SEED
    assert cam.method in {f"{m}+refined" for m in ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS")} | {
        "TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS"}


def test_joint_readings_drive_the_flange_poses(run):
    res = run.results["wrist"]
    from cell.robot.kinematics import ArmKinematics

    kin = ArmKinematics()
    for v in res.capture.views:
        assert np.allclose(kin.pose(v.q_read, "flange"), v.T_base_flange, atol=1e-12)


def test_cli_writes_the_file_and_the_report(tmp_path, capsys):
    out, report = tmp_path / "calib.json", tmp_path / "report.json"
    code = cell_main(["calibrate", "--poses", "5", "--seed", "11", "--out", str(out), "--report", str(report),
                      "--no-touch"])
    assert code == 0
    text = capsys.readouterr().out
    assert "hand-eye T_flange_camera" in text and "DANIILIDIS" in text and "refined" in text
    calib = load_calibration(out)
    assert calib.names == ("wrist",) and calib.camera("wrist").seed == 11
    data = json.loads(report.read_text())
    assert set(data["cameras"]["wrist"]["intrinsics"]) >= {
        "fx_rel_err", "fy_rel_err", "cx_err_px", "cy_err_px", "k1_rel_err", "reproj_rms_px",
        "views_used", "views_rejected"}
    assert data["cameras"]["wrist"]["touch_err_mm"] is None


def test_cli_errors_name_the_problem(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        cell_main(["calibrate", "--camera", "side", "--out", str(tmp_path / "c.json")])
    assert exc.value.code == 2
    assert "invalid choice: 'side'" in capsys.readouterr().err
    assert cell_main(["calibrate", "--out", str(tmp_path / "none" / "c.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "c.json").exists()


def test_detect_through_a_calibration_file(run, tmp_path, world_factory, capsys):
    truth = world_factory().camera_model("overhead")  # a fixed camera's entry, as eye-to-hand will write it
    overhead = CameraCalibration(
        name="overhead", width=truth.width, height=truth.height, K=truth.K, dist=truth.dist,
        pose_name="T_base_camera", pose=truth.T_world_camera, rms=0.05, method="SHAH", scenario="test",
        seed=SEED)
    path = tmp_path / "calib.json"
    write_calibration(path, CalibrationFile((run.calibration.camera("wrist"), overhead)))
    image = tmp_path / "grey.png"
    cv2.imwrite(str(image), np.full((480, 640, 3), 128, np.uint8))
    args = ["detect", str(image), "--camera", str(path)]
    assert cell_main([*args, "--camera-name", "overhead"]) == 0
    assert "0 detection(s)" in capsys.readouterr().out
    assert cell_main([*args, "--camera-name", "wrist"]) == 2
    assert "needs the flange pose" in capsys.readouterr().err
    assert cell_main(args) == 2
    err = capsys.readouterr().err
    assert "is a calibration file: name its camera with --camera-name" in err
    assert "(cameras in it: 'wrist', 'overhead')" in err


def test_same_scenario_and_seed_give_the_same_calibration():
    scenario = scenario_from_dict({"seed": 13, "calibration": {"poses": 4}})
    a, b = (run_calibration(scenario, touch=False) for _ in range(2))
    assert a.calibration.to_dict() == b.calibration.to_dict()
    assert _timeless(a.report) == _timeless(b.report)


def _timeless(report: dict) -> dict:
    """The report without its wall times (the run's and each camera's)."""
    out = {k: v for k, v in report.items() if k != "wall_s"}
    out["cameras"] = {name: {k: v for k, v in c.items() if k != "wall_s"}
                      for name, c in report["cameras"].items()}
    return out


def test_progress_is_shown_only_on_a_terminal():
    import io

    from cell.calib.cli import _progress

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    assert _progress(io.StringIO()) is None
    term = Terminal()
    show = _progress(term)
    show(1, 2, "tilt 10.0 deg")
    show(2, 2, "tilt 20.0 deg")
    assert term.getvalue() == ("\rcalibrate: view 1/2 (tilt 10.0 deg)\x1b[K"
                               "\rcalibrate: view 2/2 (tilt 20.0 deg)\x1b[K\n")


def _keep(intrinsic_rms: float, closed_form: float, refined: float) -> bool:
    return keep_refinement(SimpleNamespace(rms=intrinsic_rms), SimpleNamespace(consistency_px=closed_form),
                           SimpleNamespace(rms_px=refined))


def test_the_refinement_is_kept_only_when_better_than_the_closed_form_and_near_the_pixel_rms():
    assert MODEL_RATIO == 2.0
    assert _keep(0.1, 0.5, 0.15)  # better than the closed form, within 2x the pixel RMS
    assert _keep(0.1, 0.5, 0.2)  # at 2x: kept
    assert not _keep(0.1, 0.5, 0.25)  # over 2x the pixel RMS: the joint readings are noisy
    assert not _keep(0.1, 0.5, 0.4)
    assert not _keep(0.1, 0.12, 0.15)  # within 2x but worse than the closed form
    assert not _keep(0.1, 0.15, 0.15)  # no better: not kept


def test_too_few_reachable_views_is_one_calibration_error(monkeypatch, world_factory):
    world = world_factory(arm=True, seed=7)
    rig = capture.Rig(world, joint_noise=0.0, rng=np.random.default_rng(7))
    monkeypatch.setattr(capture, "reach_view", lambda rig, plan, q_hub: "unreachable")
    settings = scenario_from_dict({"seed": 7, "calibration": {"poses": 3}}).calibration
    with pytest.raises(CalibrationError, match=r"only 0 of 12 planned views were reachable \(12 unreachable"):
        capture.capture_views(rig, settings)
