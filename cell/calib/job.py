"""The calibration job: build the cell, calibrate its cameras, score against ground truth.

``run_calibration`` is what ``cell calibrate`` runs. For the wrist camera it builds the
``World`` of the scenario and calibrates the camera from images of the table's board and
joint readings only (:func:`cell.calib.wrist.calibrate_wrist`); for the overhead camera
it builds the cell with the checkerboard plate on the tool and calibrates from images of
that plate and joint readings only (:func:`cell.calib.overhead.calibrate_overhead`);
``all`` does both, wrist first, each in its own world, and the file holds both cameras.
Then, for the report only, it reads the simulator's ground truth (the true camera models,
mount and pose) and runs each camera's touch test.

The overhead camera's cell: the belt stands still during its calibration (as a cell is
calibrated: nothing rides into the views), and for its touch test three parts of the run
are put on the belt in the camera's view at seeded places and left to settle.

Randomness: each camera draws its views, its joint-reading noise and (overhead) its touch
parts from its own child stream of ``SeedSequence(seed)`` (the world uses children 0 and
1, the wrist 2, the overhead 3), so a camera's result is the same alone and with ``all``,
and the same scenario and seed give the same calibration.

Rendering: the calibration views are rendered with ``calibration.multisample`` samples
per pixel (default 4). A real sensor integrates the light over each pixel's area; the
simulator's default render takes one sample per pixel, which puts every edge on a whole
pixel and moves board corners by up to ~0.3 px (README, Calibration).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from cell.calib.board import Board
from cell.calib.calfile import CalibrationFile
from cell.calib.capture import Progress, Rig
from cell.calib.overhead import OverheadCalibration, calibrate_overhead
from cell.calib.report import CameraTruth, score_camera
from cell.calib.touch import PART_STANDOFF, touch_parts, touch_test, touch_view
from cell.calib.transforms import invert, make_transform
from cell.calib.wrist import WristCalibration, calibrate_wrist
from cell.errors import CalibrationError

__all__ = ["CAMERAS", "CalibrationRun", "run_calibration"]

CAMERAS = ("wrist", "overhead", "all")
_STREAM = {"wrist": 2, "overhead": 3}  # child of SeedSequence(seed) per camera (the world uses 0, 1)
_TOUCH_PARTS = 3
_TOUCH_AREA = (0.10, 0.035)  # m: half-ranges along and across the belt, around the pick zone
_TOUCH_GAP = 0.07  # m: least distance between two touch parts' centres


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """A finished calibration: the ``calibration`` (what the file holds), each camera's
    full ``results``, the ``report`` (JSON-ready, errors against ground truth) and the
    ``wall_s`` it took (s)."""

    calibration: CalibrationFile
    results: dict[str, WristCalibration | OverheadCalibration]
    report: dict
    wall_s: float


def _check_camera(camera: str) -> tuple[str, ...]:
    if camera not in CAMERAS:
        raise CalibrationError(f"unknown camera {camera!r}; valid: {', '.join(CAMERAS)}")
    return ("wrist", "overhead") if camera == "all" else (camera,)


def _world_base() -> np.ndarray:
    """``T_world_base`` (4x4, m): the arm's base in the cell, from the cell's drawings
    (``layout.ARM_BASE``: the world origin, axes aligned): a surveyed transform."""
    from cell.sim.layout import ARM_BASE

    return make_transform(np.eye(3), ARM_BASE)


def _wrist_truth(world: object) -> CameraTruth:
    """GROUND TRUTH of the wrist camera from the simulator, for scoring only: its true
    intrinsics, distortion and mount (the flange site's pose and the camera's, now)."""
    import mujoco

    mujoco.mj_forward(world.model, world.data)
    site = world.data.site("arm/flange")
    T_world_flange = make_transform(site.xmat.reshape(3, 3), site.xpos)
    model = world.camera_model("wrist")
    return CameraTruth(model.K.copy(), model.dist.copy(), "T_flange_camera",
                       invert(T_world_flange) @ model.T_world_camera)


def _overhead_truth(world: object) -> CameraTruth:
    """GROUND TRUTH of the overhead camera from the simulator, for scoring only: its true
    intrinsics, distortion and pose in the base frame."""
    model = world.camera_model("overhead")
    return CameraTruth(model.K.copy(), model.dist.copy(), "T_base_camera",
                       invert(_world_base()) @ model.T_world_camera)


def _rng(scenario: object, camera: str) -> np.random.Generator:
    stream = _STREAM[camera]
    return np.random.default_rng(np.random.SeedSequence(scenario.seed).spawn(stream + 1)[stream])


def _run_wrist(scenario: object, *, progress: Progress | None, touch: bool) -> tuple:
    from cell.sim.fixtures import target_corners_world
    from cell.sim.world import World

    settings = scenario.calibration
    rng = _rng(scenario, "wrist")
    world = World.build(scenario)
    try:
        world.model.vis.quality.offsamples = settings.multisample  # before the camera's first render
        rig = Rig(world, joint_noise=np.radians(settings.joint_noise_deg), rng=rng)
        result = calibrate_wrist(rig, settings, scenario=scenario.name, seed=scenario.seed,
                                 progress=progress)
        truth = _wrist_truth(world)
        touched = None
        if touch:
            touched = touch_test(rig, Board.from_settings(settings), result.camera,
                                 view=touch_view(settings, rng), detector=settings.detector,
                                 true_corners=target_corners_world())
        return result, score_camera(result, truth, touched)
    finally:
        world.close()


def _place_touch_parts(world: object, rng: np.random.Generator) -> list[int]:
    """Put up to ``_TOUCH_PARTS`` parts of the run on the belt in the overhead camera's view
    (seeded places and headings, ``_TOUCH_GAP`` apart) and let them settle; their ids."""
    from cell.sim import layout

    left = len(world.parts) - world.spawned
    count = min(_TOUCH_PARTS, left)
    if count < 1:
        raise CalibrationError("touch test: every part of the run is out already; the overhead touch "
                               "test puts parts on the belt (raise parts.count or use --no-touch)")
    places: list[np.ndarray] = []
    while len(places) < count:
        p = layout.PICK_ZONE[:2] + rng.uniform(-1.0, 1.0, 2) * np.array(_TOUCH_AREA)
        if all(np.linalg.norm(p - q) >= _TOUCH_GAP for q in places):
            places.append(p)
    ids = [world.place_next_part(float(x), float(y), float(rng.uniform(0.0, 2 * np.pi))).id
           for x, y in places]
    world.step(150)  # they drop 1 mm and come to rest
    return ids


def _part_truth(world: object, ids: list[int]) -> np.ndarray:
    """GROUND TRUTH, for scoring only: ``PART_STANDOFF`` above each part's top centre (K, 3),
    base frame (m)."""
    from cell.catalogue import KINDS
    from cell.sim import layout

    T_base_world = invert(_world_base())
    points = []
    for i in ids:
        position, _ = world.part_pose(i)
        top = layout.BELT_TOP + KINDS[world.parts[i - 1].kind].height + PART_STANDOFF
        points.append(T_base_world[:3, :3] @ np.array([position[0], position[1], top]) + T_base_world[:3, 3])
    return np.array(points)


def _run_overhead(scenario: object, *, progress: Progress | None, touch: bool) -> tuple:
    from cell.sim.world import World

    settings = scenario.calibration
    rng = _rng(scenario, "overhead")
    still = dataclasses.replace(scenario, conveyor=dataclasses.replace(scenario.conveyor, speed=0.0))
    world = World.build(still, flange_board=True, msaa=settings.multisample)
    try:
        rig = Rig(world, joint_noise=np.radians(settings.joint_noise_deg), rng=rng)
        result = calibrate_overhead(rig, settings, lens=scenario.camera, scenario=scenario.name,
                                    seed=scenario.seed, progress=progress)
        truth = _overhead_truth(world)
        touched = None
        if touch:
            ids = _place_touch_parts(world, rng)
            touched = touch_parts(rig, result.camera, vision=scenario.vision, parts=len(ids),
                                  true_points=_part_truth(world, ids))
        return result, score_camera(result, truth, touched)
    finally:
        world.close()


def _check_boards(settings: object, names: tuple[str, ...]) -> None:
    """The ``[calibration]`` boards are the simulated cell's: the keys describe the board
    the detector looks for, and in this cell that board is fixed (a ``CalibrationError``
    naming the keys and the cell's board otherwise: another board was found nowhere, or
    found with the wrong square size, and calibrated a wrong camera without a word)."""
    from cell.sim import flange_board, layout

    boards = {"wrist": ("board", layout.TARGET_INNER_CORNERS, layout.TARGET_SQUARE,
                        "the board on the table"),
              "overhead": ("flange_board", flange_board.INNER_CORNERS, flange_board.SQUARE,
                           "the plate on the tool")}
    for name in names:
        key, corners, square, what = boards[name]
        given = (tuple(int(n) for n in getattr(settings, f"{key}_inner_corners")),
                 float(getattr(settings, f"{key}_square")))
        if given != (tuple(corners), square):
            raise CalibrationError(
                f"calibration.{key}_inner_corners = {list(given[0])} and calibration.{key}_square "
                f"= {given[1]:g} m: {what} of the simulated cell (the {name} camera's target) has "
                f"{corners[0]}x{corners[1]} inner corners of {square:g} m squares; these keys "
                "describe the board the camera looks for, here that one")


def run_calibration(scenario: object, *, camera: str = "wrist", progress: Progress | None = None,
                    touch: bool = True) -> CalibrationRun:
    """Calibrate ``camera`` (``wrist``, ``overhead`` or ``all``) of ``scenario`` in fresh
    simulated cells; score it (and, with ``touch``, run the touch tests).
    ``progress(done, total, note)`` follows the views."""
    from cell.scenario import check_scenario

    check_scenario(scenario, "run_calibration", CalibrationError)
    names = _check_camera(camera)
    settings = scenario.calibration
    _check_boards(settings, names)
    t0 = time.perf_counter()
    results, reports = {}, {}
    for name in names:
        t_camera = time.perf_counter()
        run = _run_wrist if name == "wrist" else _run_overhead
        results[name], reports[name] = run(scenario, progress=progress, touch=touch)
        reports[name]["wall_s"] = time.perf_counter() - t_camera
    wall = time.perf_counter() - t0
    report = {
        "scenario": scenario.name, "seed": scenario.seed, "poses": settings.poses,
        "joint_noise_deg": settings.joint_noise_deg, "distortion_true": list(scenario.sensor.distortion),
        "cameras": reports, "wall_s": wall,
    }
    calibration = CalibrationFile(tuple(results[n].camera for n in names))
    return CalibrationRun(calibration, results, report, wall)
