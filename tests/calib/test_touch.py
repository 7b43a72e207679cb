"""The wrist camera's touch test measures a calibration's miss; it does not drive the cup
into the board when the calibration puts the board too low (guarded touches)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

import cell.calib.touch as touch_module
import cell.vision.detector as detector_module
from cell.calib.board import Board
from cell.calib.calfile import CameraCalibration
from cell.calib.capture import Rig
from cell.calib.touch import TOUCH_STANDOFF, PartTouchResult, TouchResult, touch_parts, touch_test, touch_view
from cell.calib.transforms import invert, make_transform
from cell.cli import main as cell_main
from cell.scenario import scenario_from_dict
from cell.sim.fixtures import target_corners_world
from cell.sim.layout import CONVEYOR_Y


def _touch_with_camera_off_by(world_factory, depth: float) -> TouchResult:
    """The touch test through the wrist camera's TRUE model, its mount moved ``depth`` (m)
    along the optical axis: seen straight down, the board comes out ``depth`` lower than it
    is (into the table when positive)."""
    scenario = scenario_from_dict({"seed": 5})
    settings = scenario.calibration
    world = world_factory(arm=True, seed=5)
    world.model.vis.quality.offsamples = settings.multisample
    mujoco.mj_forward(world.model, world.data)
    site = world.data.site("arm/flange")
    model = world.camera_model("wrist")
    T_flange_camera = invert(make_transform(site.xmat.reshape(3, 3), site.xpos)) @ model.T_world_camera
    moved = T_flange_camera @ make_transform(np.eye(3), [0.0, 0.0, depth])
    cam = scenario.camera
    camera = CameraCalibration("wrist", cam.width, cam.height, model.K.copy(), model.dist.copy(),
                               "T_flange_camera", moved, 0.05, "test", "test", 5)
    rng = np.random.default_rng(5)
    rig = Rig(world, joint_noise=0.0, rng=rng)
    return touch_test(rig, Board.from_settings(settings), camera, view=touch_view(settings, rng),
                      detector=settings.detector, true_corners=target_corners_world())


@pytest.mark.parametrize("depth", [0.015, 0.08])
def test_a_board_seen_too_low_is_a_large_touch_error_not_a_crash(world_factory, depth):
    # 15 mm: the cup meets the board on the way down; 80 mm: the target lies below the
    # table (the cup is sent down to its top and meets the board first). Before the guard:
    # CalibrationError (15 mm: 'arm did not settle ... blocked'; 80 mm: 'below the table').
    res = _touch_with_camera_off_by(world_factory, depth)
    assert res.blocked == (True, True, True)
    board_face = res.truth[:, 2] - TOUCH_STANDOFF
    assert np.all(res.landed[:, 2] > board_face)  # the cup stopped on the board, not in it
    assert np.all(res.targets[:, 2] < board_face + 0.002)  # where it was sent: within the lip's reach
    # the miss is where the calibration sent the TCP, not where the board stopped it
    assert np.allclose(res.errors_mm, 1000 * depth, atol=2.0)
    assert np.all(res.errors_mm >= 1000 * np.linalg.norm(res.landed - res.truth, axis=1))


def test_a_board_seen_too_high_is_touched_in_the_air(world_factory):
    res = _touch_with_camera_off_by(world_factory, -0.015)
    assert res.blocked == (False, False, False)
    assert np.allclose(res.landed, res.targets, atol=1e-4)
    assert np.allclose(res.errors_mm, 15.0, atol=2.0)


def test_the_true_calibration_touches_its_points(world_factory):
    res = _touch_with_camera_off_by(world_factory, 0.0)
    assert res.blocked == (False, False, False)
    assert res.errors_mm.max() < 0.5


def test_cli_with_joint_noise_writes_the_calibration_and_the_touch_error(tmp_path, capsys):
    # seed 0 at 0.5 deg: the calibration puts two corners over 3 mm too low (the cup met
    # the board; before: exit 2, 'arm did not settle ... blocked or saturated')
    out, report = tmp_path / "calib.json", tmp_path / "report.json"
    code = cell_main(["calibrate", "--camera", "wrist", "--seed", "0", "--set",
                      "calibration.joint_noise_deg=0.5", "--out", str(out), "--report", str(report)])
    assert code == 0 and out.exists()
    wrist = json.loads(report.read_text())["cameras"]["wrist"]
    assert len(wrist["touch"]["errors_mm"]) == 3 and wrist["touch_err_mm"] > 5.0
    text = capsys.readouterr().out
    assert "touch test: corners" in text and "warning: the cup met something short of" in text
    assert sum(wrist["touch"]["blocked"]) >= 1


def test_the_overhead_touch_test_touches_the_most_confident_parts_and_locates_them_on_the_belt(monkeypatch):
    # three detections of known kinds on the belt, one touch wanted: the most confident is
    # touched (a spurious, unsure one must not be); its truth is the nearest true point
    dets = [SimpleNamespace(position=(0.40, CONVEYOR_Y), kind="washer", kind_confidence=0.3),
            SimpleNamespace(position=(0.50, CONVEYOR_Y + 0.01), kind="washer", kind_confidence=0.9),
            SimpleNamespace(position=(0.60, CONVEYOR_Y), kind="hex_nut", kind_confidence=0.6)]

    class FakeDetector:
        def __init__(self, vision):
            pass

        def detect(self, image, camera):
            return list(dets)

    monkeypatch.setattr(detector_module, "PartDetector", FakeDetector)
    monkeypatch.setattr(touch_module, "_touch", lambda rig, target, yaw, what: (np.asarray(target), False))
    rig = SimpleNamespace(hold_and_look=lambda name: (np.zeros((4, 4, 3), np.uint8), None))
    camera = SimpleNamespace(name="overhead", pose_name="T_base_camera", camera_model=lambda: None)
    # true touch points: z 0.3 m off the target's (a mistaken kind's height): the belt figure ignores it
    truth = np.array([[0.503, CONVEYOR_Y + 0.014, 0.3], [0.401, CONVEYOR_Y, 0.3]])
    res = touch_parts(rig, camera, vision=None, parts=1, true_points=truth)
    assert isinstance(res, PartTouchResult)
    assert res.kinds == ("washer",) and np.allclose(res.targets[0, :2], [0.50, CONVEYOR_Y + 0.01])
    assert np.allclose(res.truth, truth[:1])
    assert np.allclose(res.located_mm, [5.0])  # 3 mm along, 4 mm across the belt; not the height
