"""The touch test: touch the point you see, through the calibration, and measure the miss.

From a new view (a pose none of the calibration views used) the wrist camera finds the
board; ``cv2.solvePnP`` with the calibrated intrinsics gives ``T_camera_board``, and the
board corners' positions in the base frame follow through the calibrated hand-eye
transform and the forward kinematics of the joint readings:

    p_base = T_base_flange(q_read) T_flange_camera T_camera_board p_board

The arm then drives its TCP (tool pointing down) to each chosen corner, ``TOUCH_STANDOFF``
above the board along the board's seen normal so that the cup does not press on it,
and the simulator's ground truth says where the TCP landed against where that point
truly is (the same standoff above the true corner). This is the only place, besides the
report, where ground truth is read, and it is read only to score.

Every touch is guarded: the TCP goes to ``_APPROACH`` above its point, then straight down
(never below the table's top, z = 0 in the cell's drawings, which the board lies on), and
both motions stop where the cup meets something (the vacuum switch, the cup's touch sensor,
reads over ``_CONTACT``): the arm holds where it stopped, then backs off. A calibration that
puts the board's face too low (behind where it is) by about the standoff or more sends the
cup onto the board (the lip meets it 2 mm off its face); that touch is ``blocked``, and is
scored as the distance from the point the calibration sent the TCP to (which the board kept
it from) to the truth, never less than where the TCP came to rest is from the truth. The
touch test measures the miss; it does not fail on it.

The overhead camera's touch test (:func:`touch_parts`) touches what that camera is for:
parts on the belt. ``cell.vision``'s ``PartDetector`` finds them in one overhead image
through the calibrated camera model (the fixed camera's ``T_base_camera``; the base frame
is the cell's world frame), which puts each part's footprint centroid on the belt; the
TCP (tool down) is driven to ``PART_STANDOFF`` above the part's top there (the belt's
height from the cell's drawings plus the detected kind's catalogue height). The larger
standoff keeps the plate on the tool, which reaches 5 mm past the cup face at 65 mm from
the tool axis, clear of the belt and the other parts. The miss is measured as for the
wrist camera (guarded too), against the same standoff above the part's true top centre; it
holds the detector's own position error (README, Vision) besides the calibration's.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import mujoco
import numpy as np

from cell.calib.board import Board, detect_board
from cell.calib.calfile import CameraCalibration
from cell.calib.capture import Rig, move_via_hub, reach_view
from cell.calib.intrinsics import one_thread
from cell.calib.planning import ViewPlan, look_at
from cell.calib.transforms import invert, make_transform, transform_from_rvec
from cell.errors import CalibrationError, IKError, MotionError
from cell.robot.ik import tool_yaw
from cell.robot.suction import SuctionCup

__all__ = ["PART_STANDOFF", "TOUCH_STANDOFF", "PartTouchResult", "TouchResult", "touch_parts", "touch_test",
           "touch_view"]

TOUCH_STANDOFF = 0.005  # m: the TCP stops this far above the board's face
PART_STANDOFF = 0.02  # m: the TCP stops this far above a part's top (overhead touch test)
_BELT_EDGE = 0.01  # m: a detection nearer the belt's edge is not a part on the belt (the edge strip)
_APPROACH = 0.05  # m: above the point before the last, vertical, move
_CONTACT = 0.2  # N: a vacuum-switch reading over this is the cup touching something (guarded moves)
_REST = 0.3  # s: the arm holds still this long before the TCP's resting position is read
_TABLE_TOP = 0.0  # m: z of the table's top (cell.sim.layout), which the board lies on


@dataclass(frozen=True, eq=False)
class _Touched:
    """``targets`` (K, 3) where the calibration placed the touch points, ``landed`` (K, 3)
    where the TCP came to rest and ``truth`` (K, 3) where the points are (both simulator
    truth), base frame, metres; ``blocked`` (K bools; empty: none) the touches that did not
    reach their target: the cup met something (the board, a part) on the way and stopped
    there, or the target lay below the table's top."""

    targets: np.ndarray
    landed: np.ndarray
    truth: np.ndarray
    blocked: tuple[bool, ...] = ()

    @property
    def errors_mm(self) -> np.ndarray:
        """Distance (mm) from each landed TCP to its true point; for a blocked touch, from
        its target (where the calibration sent the TCP) when that is farther."""
        landed = 1000.0 * np.linalg.norm(self.landed - self.truth, axis=1)
        if not any(self.blocked):
            return landed
        sent = 1000.0 * np.linalg.norm(self.targets - self.truth, axis=1)
        return np.where(np.asarray(self.blocked, bool), np.maximum(landed, sent), landed)


@dataclass(frozen=True, eq=False)
class TouchResult(_Touched):
    """The wrist camera's touch test (see :class:`_Touched`); ``corner_ids`` the board
    corners touched."""

    corner_ids: tuple[int, ...] = ()


def _board_seen(rig: Rig, board: Board, camera: CameraCalibration, *, detector: str) -> np.ndarray:
    """``T_base_board`` (4x4, m) from one new view of the board through the calibration."""
    image, q_read = rig.hold_and_look(camera.name)
    view = detect_board(image, board, first=detector)
    if view is None:
        raise CalibrationError("touch test: the board is not found in the touch view")
    with one_thread():
        ok, rvec, tvec = cv2.solvePnP(board.object_points(), view.corners, camera.K, camera.dist,
                                      flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise CalibrationError("touch test: solvePnP failed on the touch view")
    return rig.kin.pose(q_read, "flange") @ camera.pose @ transform_from_rvec(rvec, tvec)


def _guarded_move(rig: Rig, q_goal: np.ndarray, *, what: str) -> bool:
    """Drive to ``q_goal`` (rad) as ``ArmDriver.move`` does, watching the vacuum switch
    (:meth:`~cell.robot.motion.ArmDriver.move_until`): True when the arm settled there;
    False when the cup touched something on the way (a reading over ``_CONTACT``): the
    arm then holds where its joints were at that instant, ``_REST`` s."""
    cup = SuctionCup(rig.world.model, rig.world.data)
    if rig.driver.move_until(q_goal, lambda: cup.reading() > _CONTACT, what=what):
        return True
    rig.driver.wait(_REST)
    return False


def _touch(rig: Rig, target: np.ndarray, yaw: float, what: str) -> tuple[np.ndarray, bool]:
    """Drive the TCP to ``target`` (m, tool down, heading ``yaw``) from above, guarded (see
    the module docstring); the TCP's true resting position (m), read from the simulator
    (scoring only), and whether it fell short of the target (blocked)."""
    q_now = rig.driver.joint_positions()
    low = target[2] < _TABLE_TOP  # the board lies on the table: the cup meets it on the way
    target = np.array([target[0], target[1], max(target[2], _TABLE_TOP)])
    above = target + np.array([0.0, 0.0, _APPROACH])
    q_above = rig.ik.solve(above, yaw, rig.ik.seed_towards(above, yaw, q_now), what=f"above {what}")
    q_at = rig.ik.solve(target, yaw, q_above, what=what)
    if not _guarded_move(rig, q_above, what=f"above {what}"):
        back = q_now  # blocked on the way down to the approach point: back whence it came
    elif not _guarded_move(rig, q_at, what=what):
        back = q_above
    else:
        rig.driver.wait(0.3)
        back = None
    world = rig.world
    mujoco.mj_forward(world.model, world.data)
    landed = world.data.site("arm/tcp").xpos.copy()
    rig.driver.move(q_above if back is None else back, what=f"above {what}")
    return landed, back is not None or low


def touch_view(settings: object, rng: np.random.Generator) -> ViewPlan:
    """The touch view: straight down over the board from the middle of the distance range,
    aim and heading drawn from ``rng`` (a view of its own, none of the calibration views);
    the flange pose by the rough camera mount of the settings."""
    centre = np.asarray(settings.board_position, float)
    aim = centre + np.append(rng.uniform(-0.02, 0.02, 2), 0.0)
    distance = float(np.mean(settings.distance))
    roll = float(rng.uniform(-0.5, 0.5))
    T_base_camera = look_at(aim + np.array([0.0, 0.0, distance]), aim, roll=roll)
    T_flange_camera_guess = make_transform(np.eye(3), settings.camera_offset)
    return ViewPlan(T_base_camera, T_base_camera @ invert(T_flange_camera_guess), 0.0, 0.0,
                    float(np.degrees(roll)), distance)


def touch_test(rig: Rig, board: Board, camera: CameraCalibration, *, view: ViewPlan, detector: str,
               true_corners: np.ndarray, corner_ids: tuple[int, ...] | None = None) -> TouchResult:
    """Touch board corners seen from ``view`` through the calibrated ``camera`` (a wrist
    camera: ``T_flange_camera``), detecting with ``detector`` first.

    ``true_corners`` (N, 3) are the board's true corner positions in the base frame (m,
    board index order; ground truth, for scoring only). ``corner_ids`` default to the
    first, a middle and the last corner. Raises ``CalibrationError`` when the board is
    not found or a motion fails.
    """
    if camera.pose_name != "T_flange_camera":
        raise CalibrationError(f"touch test: camera {camera.name!r} is not on the flange")
    nx, ny = board.inner_corners
    ids = corner_ids or (0, (ny // 2) * nx + nx // 2, board.count - 1)
    hub = rig.hub if rig.hub is not None else rig.driver.joint_positions()
    try:
        q_view = reach_view(rig, view, hub)
        if isinstance(q_view, str):
            raise CalibrationError(f"touch test: the touch view is {q_view}")
        move_via_hub(rig, q_view, hub)
        T_base_board = _board_seen(rig, board, camera, detector=detector)
        P = board.object_points()[list(ids)]
        targets = P @ T_base_board[:3, :3].T + T_base_board[:3, 3] + TOUCH_STANDOFF * T_base_board[:3, 2]
        yaw = tool_yaw(T_base_board[:3, :3])
        touches = [_touch(rig, target, yaw, f"board corner {i}")
                   for i, target in zip(ids, targets, strict=True)]
    except (IKError, MotionError) as exc:
        raise CalibrationError(f"touch test: {exc}") from None
    truth = np.asarray(true_corners, float)[list(ids)] + np.array([0.0, 0.0, TOUCH_STANDOFF])
    return TouchResult(targets, np.array([t[0] for t in touches]), truth, tuple(t[1] for t in touches),
                       corner_ids=tuple(int(i) for i in ids))


@dataclass(frozen=True, eq=False)
class PartTouchResult(_Touched):
    """The overhead camera's touch test (see :class:`_Touched`): the ``kinds`` detected."""

    kinds: tuple[str, ...] = ()

    @property
    def located_mm(self) -> np.ndarray:
        """Distance (mm) on the belt from each point located through the camera to the truth:
        the camera's and the detector's share of the miss, without the robot's."""
        return 1000.0 * np.linalg.norm(self.targets[:, :2] - self.truth[:, :2], axis=1)


def touch_parts(rig: Rig, camera: CameraCalibration, *, vision: object, parts: int,
                true_points: np.ndarray, yaw: float = 0.0) -> PartTouchResult:
    """Touch the parts on the belt that the fixed ``camera`` (``T_base_camera``) sees, each
    found by ``PartDetector(vision)`` in one image through the calibrated model (see the
    module docstring); the arm must be out of the camera's view.

    ``parts`` is how many parts the test put on the belt; ``true_points`` (K, 3) are their
    true touch points, ``PART_STANDOFF`` above each part's top centre, base frame (m; ground
    truth, for scoring only): each detection is scored against the nearest. The ``parts``
    detections of a known kind whose position lies on the belt, more than
    10 mm inside its edges (the cell's drawings: the detector sometimes takes a piece of the
    belt's edge for a part), the most confident first, are touched, tool heading ``yaw``
    (rad). Raises
    ``CalibrationError`` when no part is found with a position and a kind, or a motion fails.
    """
    from cell.catalogue import KINDS
    from cell.sim.layout import BELT_TOP, BELT_WIDTH, CONVEYOR_Y
    from cell.vision.detector import PartDetector

    if camera.pose_name != "T_base_camera":
        raise CalibrationError(f"touch test: camera {camera.name!r} is not a fixed camera")
    truth_all = np.asarray(true_points, float).reshape(-1, 3)
    image, _ = rig.hold_and_look(camera.name)
    inside = BELT_WIDTH / 2 - _BELT_EDGE
    found = [d for d in PartDetector(vision).detect(image, camera.camera_model())
             if d.position is not None and d.kind in KINDS and abs(d.position[1] - CONVEYOR_Y) <= inside]
    if not found:
        raise CalibrationError(f"touch test: camera {camera.name!r} found no whole part of a known kind "
                               "on the belt")
    found = sorted(found, key=lambda d: -d.kind_confidence)[:parts]
    targets = np.array([[d.position[0], d.position[1], BELT_TOP + KINDS[d.kind].height + PART_STANDOFF]
                        for d in found])
    try:
        touches = [_touch(rig, target, yaw, f"the {d.kind} seen at {np.round(target[:2], 3).tolist()} m")
                   for d, target in zip(found, targets, strict=True)]
    except (IKError, MotionError) as exc:
        raise CalibrationError(f"touch test: {exc}") from None
    nearest = np.argmin(np.linalg.norm(targets[:, None, :2] - truth_all[None, :, :2], axis=2), axis=1)
    return PartTouchResult(targets, np.array([t[0] for t in touches]), truth_all[nearest],
                           tuple(t[1] for t in touches), kinds=tuple(d.kind for d in found))
