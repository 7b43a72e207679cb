"""The calibration job: build the cell, calibrate its cameras, score against ground truth.

``run_calibration`` is what ``cell calibrate`` runs. It builds the ``World`` of the
scenario, calibrates the wrist camera from images and joint readings only
(:func:`cell.calib.wrist.calibrate_wrist`), and then, for the report only, reads the
simulator's ground truth (the true camera model and mount) and runs the touch test.

Randomness: one ``np.random.Generator`` from the scenario's seed (its own child stream of
``SeedSequence(seed)``, apart from the world's) draws the views and the joint-reading
noise, so the same scenario and seed give the same calibration.

Rendering: the calibration views are rendered with ``calibration.multisample`` samples
per pixel (default 4). A real sensor integrates the light over each pixel's area; the
simulator's default render takes one sample per pixel, which puts every edge on a whole
pixel and moves board corners by up to ~0.3 px (README, Calibration).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from cell.calib.board import Board
from cell.calib.calfile import CalibrationFile
from cell.calib.capture import Progress, Rig
from cell.calib.report import WristTruth, score_wrist
from cell.calib.touch import touch_test, touch_view
from cell.calib.transforms import invert, make_transform
from cell.calib.wrist import WristCalibration, calibrate_wrist
from cell.errors import CalibrationError

__all__ = ["CAMERAS", "CalibrationRun", "run_calibration"]

CAMERAS = ("wrist", "overhead", "all")
_STREAM = 2  # child index of SeedSequence(seed) for the calibration (the world uses 0 and 1)


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """A finished calibration: the ``calibration`` (what the file holds), each camera's
    full ``results``, the ``report`` (JSON-ready, errors against ground truth) and the
    ``wall_s`` it took (s)."""

    calibration: CalibrationFile
    results: dict[str, WristCalibration]
    report: dict
    wall_s: float


def _check_camera(camera: str) -> None:
    if camera not in CAMERAS:
        raise CalibrationError(f"unknown camera {camera!r}; valid: {', '.join(CAMERAS)}")
    if camera in ("overhead", "all"):
        raise CalibrationError(
            f"--camera {camera}: the overhead camera's eye-to-hand calibration needs a checkerboard "
            "that the arm holds in front of the fixed camera, and this cell has no such board yet "
            "(only the one lying on the table, which the overhead camera cannot see from many "
            "poses); calibrate the wrist camera with --camera wrist")


def wrist_truth(world: object) -> WristTruth:
    """GROUND TRUTH of the wrist camera from the simulator, for scoring only: its true
    intrinsics, distortion and mount (the flange site's pose and the camera's, now)."""
    import mujoco

    mujoco.mj_forward(world.model, world.data)
    site = world.data.site("arm/flange")
    T_world_flange = make_transform(site.xmat.reshape(3, 3), site.xpos)
    model = world.camera_model("wrist")
    return WristTruth(model.K.copy(), model.dist.copy(), invert(T_world_flange) @ model.T_world_camera)


def run_calibration(scenario: object, *, camera: str = "wrist", progress: Progress | None = None,
                    touch: bool = True) -> CalibrationRun:
    """Calibrate ``camera`` of ``scenario`` in a fresh simulated cell; score it (and, with
    ``touch``, run the touch test). ``progress(done, total, note)`` follows the views."""
    from cell.sim.fixtures import target_corners_world
    from cell.sim.world import World

    _check_camera(camera)
    t0 = time.perf_counter()
    settings = scenario.calibration
    rng = np.random.default_rng(np.random.SeedSequence(scenario.seed).spawn(_STREAM + 1)[_STREAM])
    world = World.build(scenario)
    try:
        world.model.vis.quality.offsamples = settings.multisample  # before the camera's first render
        rig = Rig(world, joint_noise=np.radians(settings.joint_noise_deg), rng=rng)
        result = calibrate_wrist(rig, settings, scenario=scenario.name, seed=scenario.seed,
                                 progress=progress)
        truth = wrist_truth(world)
        touched = None
        if touch:
            touched = touch_test(rig, Board.from_settings(settings), result.camera,
                                 view=touch_view(settings, rng), detector=settings.detector,
                                 true_corners=target_corners_world())
        camera_report = score_wrist(result, truth, touched)
    finally:
        world.close()
    wall = time.perf_counter() - t0
    report = {
        "scenario": scenario.name, "seed": scenario.seed, "poses": settings.poses,
        "joint_noise_deg": settings.joint_noise_deg, "distortion_true": list(scenario.sensor.distortion),
        "cameras": {"wrist": camera_report}, "wall_s": wall,
    }
    return CalibrationRun(CalibrationFile((result.camera,)), {"wrist": result}, report, wall)
