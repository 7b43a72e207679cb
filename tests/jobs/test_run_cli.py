"""``cell run``: the files it writes, its replay (checked by rerun's own tools), its errors."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from cell.errors import JobError
from cell.jobs import run
from cell.jobs.sort import overhead_model
from cell.scenario import scenario_from_dict

ROOT = Path(__file__).parents[2]


def _cell(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cell.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, env={**os.environ, "MUJOCO_GL": "egl", **(env or {})}, timeout=600)


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """One short run with a report and a replay, calibrating first (as make demo does)."""
    out = tmp_path_factory.mktemp("run")
    r = _cell("run", "scenarios/sort.toml", "--set", "parts.count=2", "--report",
              str(out / "report.json"), "--replay", str(out / "replay.rrd"))
    return out, r


def test_run_writes_report_calibration_image_and_replay(demo):
    out, r = demo
    assert r.returncode == 0, r.stderr
    assert "the overhead camera was calibrated first" in r.stdout
    assert "sort accuracy" in r.stdout and "open the replay with" in r.stdout
    report = json.loads((out / "report.json").read_text())
    assert report["accounting"]["spawned"] == 2
    assert set(report["metrics"]) >= {
        "sort_accuracy", "classification_accuracy", "pick_success", "position_error_mm_p50",
        "position_error_mm_p95", "cycle_time_s_mean", "parts_per_minute", "sim_time_s",
        "wall_time_s", "real_time_factor"}
    assert report["calibration"]["file"] == str(out / "report.calibration.json")
    assert (out / "detections.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary left


def test_the_calibration_written_is_reused(demo, tmp_path):
    out, _ = demo
    r = _cell("run", "scenarios/sort.toml", "--set", "parts.count=1", "--calibration",
              str(out / "report.calibration.json"), "--report", str(tmp_path / "r.json"))
    assert r.returncode == 0, r.stderr
    assert "calibrating" not in r.stderr
    assert json.loads((tmp_path / "r.json").read_text())["calibration"]["file"] == str(
        out / "report.calibration.json")
    assert not (tmp_path / "r.calibration.json").exists()


def test_a_run_that_saw_no_part_leaves_no_earlier_image_beside_its_report(demo, tmp_path):
    """The folder holds one run's files: a run whose captures saw no part (the belt stands
    still) removes the detections.png an earlier run wrote there (it stayed, beside the
    new report)."""
    out, _ = demo
    calibration = str(out / "report.calibration.json")
    first = _cell("run", "scenarios/sort.toml", "--set", "parts.count=1", "--calibration",
                  calibration, "--report", str(tmp_path / "report.json"))
    assert first.returncode == 0 and (tmp_path / "detections.png").is_file(), first.stderr
    still = _cell("run", "scenarios/sort.toml", "--set", "parts.count=1", "--set",
                  "conveyor.speed=0", "--set", "sort.arrival_timeout=1", "--calibration",
                  calibration, "--report", str(tmp_path / "report.json"))
    assert still.returncode == 0, still.stderr
    assert "detections.png" not in still.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]


def test_replay_verifies_with_rerun_and_holds_the_run(demo):
    out, _ = demo
    env = {**os.environ, "CI": "1"}
    verify = subprocess.run([sys.executable, "-m", "rerun_cli", "rrd", "verify", str(out / "replay.rrd")],
                            capture_output=True, text=True, env=env, timeout=120)
    assert verify.returncode == 0, verify.stderr
    stats = subprocess.run([sys.executable, "-m", "rerun_cli", "rrd", "stats", str(out / "replay.rrd")],
                           capture_output=True, text=True, env=env, timeout=120)
    text = stats.stdout + stats.stderr
    for entity in ("world/overhead_camera/image", "world/overhead_camera/detections",
                   "truth/segmentation", "metrics/pick_success", "metrics/sort_accuracy"):
        assert entity in text, entity


def test_own_detector_from_examples_runs(tmp_path):
    r = _cell("run", "scenarios/sort.toml", "--set", "parts.count=2", "--set",
              "vision.detector=threshold_detector:ThresholdDetector", "--report", str(tmp_path / "r.json"),
              env={"PYTHONPATH": str(ROOT / "examples")})
    assert r.returncode == 0, r.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["detector"] == "threshold_detector:ThresholdDetector"
    a = report["accounting"]
    assert a["spawned"] == a["binned"] + a["rejected"] + a["missed"] + a["dropped"] == 2


@pytest.mark.parametrize(("args", "culprit"), [
    (("--set", "vision.detector=no_such_module:Detector"), "no_such_module"),
    (("--set", "vision.detector=cell.jobs.sort:NoSuchClass"), "NoSuchClass"),
    (("--set", "vision.detector=not a name"), "vision.detector"),
    (("--report", "/no/such/folder/r.json"), "/no/such/folder"),
    (("--replay", "."), "is a folder"),
    (("--calibration", "/no/such/calibration.json"), "/no/such/calibration.json"),
    (("--calibration", "scenarios/sort.toml"), "sort.toml"),
    (("--seed", "-1"), "--seed"),
])
def test_bad_input_is_one_line_naming_the_culprit(args, culprit, tmp_path):
    r = _cell("run", "scenarios/sort.toml", "--set", "parts.count=1", *args)
    assert r.returncode == 2
    last = r.stderr.strip().splitlines()[-1]  # (after the usage, for an option)
    assert culprit in last and "Traceback" not in r.stderr, r.stderr
    assert "no --calibration given" not in r.stderr  # no notice line before the error


def test_a_calibration_without_the_overhead_camera_is_refused(demo, tmp_path):
    out, _ = demo
    data = json.loads((out / "report.calibration.json").read_text())
    for camera in data["cameras"]:
        camera["name"] = "wrist"
    wrist_only = tmp_path / "wrist.json"
    wrist_only.write_text(json.dumps(data))
    r = _cell("run", "scenarios/sort.toml", "--calibration", str(wrist_only))
    assert r.returncode == 2 and "holds no overhead camera" in r.stderr, r.stderr
    assert "wrist.json" in r.stderr and len(r.stderr.splitlines()) == 1  # the file is named


def test_a_replay_with_rerun_turned_off_is_refused_before_the_run(tmp_path):
    r = _cell("run", "scenarios/sort.toml", "--replay", str(tmp_path / "x.rrd"),
              env={"RERUN": "Off"})
    assert r.returncode == 2 and r.stderr.splitlines() == [
        f"cell run: error: --replay {str(tmp_path / 'x.rrd')!r}: rerun logging is disabled "
        "(RERUN=Off in the environment): unset it to write a replay"]
    assert list(tmp_path.iterdir()) == [] and "calibrat" not in r.stdout


@pytest.mark.parametrize(("setting", "words"), [
    ("vision.plane_z=5", ["--calibration", "vision.plane_z"]),  # a plane it does not look down on
    # another lens (accepted before: a calibration at 40 degrees with camera.fovy = 36
    # missed 3 of 4 parts)
    ("camera.fovy=36", ["field of view of 40.0 deg", "camera.fovy is 36 deg"]),
])
def test_a_calibration_that_does_not_fit_the_scenario_is_refused_first(demo, tmp_path, setting, words):
    out, _ = demo
    r = _cell("run", "scenarios/sort.toml", "--calibration", str(out / "report.calibration.json"),
              "--set", setting, "--report", str(tmp_path / "r.json"))
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, r.stderr
    assert all(w in r.stderr for w in words), r.stderr
    assert list(tmp_path.iterdir()) == []  # refused before the run: nothing written


def test_outputs_get_the_usual_file_mode(demo):
    out, _ = demo
    mask = os.umask(0)
    os.umask(mask)
    for name in ("report.json", "report.calibration.json", "detections.png", "replay.rrd"):
        assert (out / name).stat().st_mode & 0o777 == 0o666 & ~mask, name


_EVIL = """
class Raises:
    def detect(self, image, camera):
        raise RuntimeError("boom \\x1b[31mred\\nline")
"""


def test_a_crashing_detector_is_one_escaped_line_and_leaves_no_file(demo, tmp_path):
    out, _ = demo
    (tmp_path / "evil_detector.py").write_text(_EVIL)
    files = tmp_path / "out"
    files.mkdir()
    r = _cell("run", "scenarios/sort.toml", "--set", "parts.count=1", "--calibration",
              str(out / "report.calibration.json"), "--set", "vision.detector=evil_detector:Raises",
              "--report", str(files / "r.json"), "--replay", str(files / "r.rrd"),
              env={"PYTHONPATH": str(tmp_path)})
    assert r.returncode == 2, r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert "'evil_detector:Raises'" in line and "RuntimeError: boom \\x1b[31mred\\nline" in line, line
    assert list(files.iterdir()) == []


def _run_here(capsys, *args: str) -> tuple[int, str]:
    """``cell run`` in this process: (exit status, stderr)."""
    from cell.cli import main

    code = main(["run", str(ROOT / "scenarios/sort.toml"), "--set", "parts.count=1", *args])
    return code, capsys.readouterr().err


@pytest.mark.parametrize(("args", "culprit"), [
    (("--report", "same", "--replay", "sub/../same"), "--report and --replay"),
    (("--report", "q.json", "--replay", "q.calibration.json"),
     "--replay and the calibration written beside --report"),
    (("--report", "q.json", "--replay", "detections.png"), "--replay and detections.png written beside"),
    (("--report", "detections.png"), "--report and detections.png written beside --report"),
    (("--calibration", "c.json", "--replay", "sub/../c.json"), "--calibration and --replay"),
    (("--report", ""), "--report: empty path"),
    (("--replay", ""), "--replay: empty path"),
])
def test_outputs_that_are_one_file_or_empty_are_refused(capsys, monkeypatch, tmp_path, args, culprit):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    code, err = _run_here(capsys, *args)
    assert code == 2
    (line,) = err.strip().splitlines()
    assert culprit in line, line
    assert [p.name for p in tmp_path.iterdir()] == ["sub"]


@pytest.mark.parametrize("folder", ["r.calibration.json", "detections.png"])
def test_an_unwritable_file_beside_the_report_is_refused_before_the_run(capsys, tmp_path, folder):
    (tmp_path / folder).mkdir()
    code, err = _run_here(capsys, "--report", str(tmp_path / "r.json"), "--replay", str(tmp_path / "r.rrd"))
    assert code == 2 and "is a folder" in err and folder in err, err
    assert [p.name for p in tmp_path.iterdir()] == [folder]


def test_outputs_are_written_only_when_everything_succeeded(capsys, monkeypatch, demo, tmp_path):
    out, _ = demo

    def fail(image):
        raise JobError("no PNG today")

    monkeypatch.setattr("cell.jobs.report.encode_png", fail)
    code, err = _run_here(capsys, "--calibration", str(out / "report.calibration.json"),
                          "--report", str(tmp_path / "r.json"), "--replay", str(tmp_path / "r.rrd"))
    assert code == 2 and "no PNG today" in err
    assert list(tmp_path.iterdir()) == []


def test_a_polite_kill_leaves_the_folder_as_it_was(tmp_path):
    """SIGTERM (kill, timeout, a job scheduler) unwinds the run as Ctrl-C does: one line,
    exit status 143, and the replay's temporary file removed with everything else."""
    import signal
    import time

    proc = subprocess.Popen(
        [sys.executable, "-m", "cell.cli", "run", "scenarios/sort.toml", "--set", "parts.count=3",
         "--replay", str(tmp_path / "r.rrd"), "--report", str(tmp_path / "r.json")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
        env={**os.environ, "MUJOCO_GL": "egl"},
        preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL))
    end = time.monotonic() + 120
    while not list(tmp_path.glob(".r.rrd.*")):  # the replay is being written: mid-run
        assert proc.poll() is None and time.monotonic() < end, proc.communicate()
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143 and stderr.splitlines() == ["cell run: terminated"], stderr
    assert list(tmp_path.iterdir()) == []


def _calibration_with_fovy(fovy_deg: float, height: int = 480, width: int = 640):
    fy = height / (2 * math.tan(math.radians(fovy_deg) / 2))
    model = SimpleNamespace(width=width, height=height, K=np.array([[fy, 0, width / 2], [0, fy, height / 2],
                                                                    [0, 0, 1.0]]))
    cam = SimpleNamespace(camera_model=lambda: model)
    return SimpleNamespace(names=("overhead",), camera=lambda name: cam)


def test_a_calibrated_field_of_view_more_than_2_percent_off_is_another_lens():
    scenario = scenario_from_dict({})
    fovy, size = scenario.camera.fovy, (scenario.camera.width, scenario.camera.height)
    ok = _calibration_with_fovy(fovy * 1.015, height=size[1], width=size[0])
    assert overhead_model(ok, scenario, where="cal.json").height == size[1]
    for off in (1.03, 0.97, 1.05):
        bad = _calibration_with_fovy(fovy * off, height=size[1], width=size[0])
        with pytest.raises(JobError, match="vertical field of view"):
            overhead_model(bad, scenario, where="cal.json")


def test_the_wall_time_fractions_are_fractions_of_the_run(demo):
    out, r = demo
    assert r.returncode == 0, r.stderr
    fractions = json.loads((out / "report.json").read_text())["wall_time_fractions"]
    assert fractions and all(0.0 <= v <= 1.0 for v in fractions.values()), fractions
    assert sum(fractions.values()) == pytest.approx(1.0, abs=0.05), fractions


def test_detections_png_goes_beside_the_report_whatever_folder_the_replay_is_in(tmp_path):
    (tmp_path / "reports").mkdir()
    (tmp_path / "replays").mkdir()
    args = run._parser().parse_args(["s.toml", "--report", str(tmp_path / "reports" / "r.json"),
                                     "--replay", str(tmp_path / "replays" / "r.rrd")])
    outputs = run._outputs(args)
    assert outputs.image.path == tmp_path / "reports" / "detections.png"
    assert outputs.calibration.path == tmp_path / "reports" / "r.calibration.json"
    only_replay = run._outputs(run._parser().parse_args(
        ["s.toml", "--replay", str(tmp_path / "replays" / "r.rrd")]))
    assert only_replay.image.path == tmp_path / "replays" / "detections.png"
    assert only_replay.calibration is None and only_replay.report is None
