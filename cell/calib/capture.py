"""Capture of calibration views in the simulated cell: move the arm, read its joints, render.

This module and :mod:`cell.calib.touch` are the robot side of the calibration: they drive
a ``World``; the rest of :mod:`cell.calib` works on arrays only. For each planned view
(:mod:`cell.calib.planning`) the flange pose is reached by collision-aware IK (the
``ArmIK`` model of the cell: its frame task on the TCP, its posture, joint, speed and
collision limits, here with a general target orientation rather than tool-down), the
pose and the straight joint path to it are checked for collisions (``ArmIK.collides``),
the arm drives there on its servos (``ArmDriver``) and holds still, and then the camera
takes its image and the controller reads the joints at that same instant. The flange
pose comes from pinocchio's forward kinematics of those readings: the true joint angles
plus seeded Gaussian noise of ``joint_noise_deg``, as a controller with imperfect
encoders would report them. Nothing here reads the camera's true model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from cell.calib.planning import ViewPlan, look_at, plan_views
from cell.calib.transforms import invert, make_transform
from cell.errors import CalibrationError, IKError, MotionError
from cell.robot.ik import ArmIK
from cell.robot.kinematics import ArmKinematics
from cell.robot.motion import ArmDriver
from cell.sim.arm import HOME

__all__ = [
    "Capture", "CapturedView", "Rig", "capture_views", "move_via_hub", "reach_view", "solve_flange_pose",
]

_IK_ITERATIONS = 300
_CLEARANCE = 0.01  # m: least distance of the arm to the furniture at a view
_PATH_SAMPLES = 12
_HOLD = 0.3  # s: the arm holds still this long before the picture
Progress = Callable[[int, int, str], None]


@dataclass(frozen=True, eq=False)
class CapturedView:
    """One captured view: ``image`` uint8 (H, W, 3) RGB; ``q_read`` (6,) rad the joint
    readings; ``T_base_flange`` (4x4, m) their forward kinematics; ``plan`` the wrist view
    it was meant to be (None for an overhead view: those are planned as joint angles)."""

    image: np.ndarray
    q_read: np.ndarray
    T_base_flange: np.ndarray
    plan: ViewPlan | None


@dataclass(frozen=True, eq=False)
class Capture:
    """The views of one camera: ``views`` in capture order, and how many planned poses
    were skipped as unreachable by IK (``unreachable``) or too near the cell (``blocked``)."""

    camera: str
    views: tuple[CapturedView, ...]
    unreachable: int
    blocked: int


class Rig:
    """The robot as a calibration drives it: IK, kinematics and the servo driver of
    ``world``'s arm, and the joint-reading noise (rad) with its generator."""

    def __init__(self, world: object, *, joint_noise: float, rng: np.random.Generator) -> None:
        self.world = world
        self.ik = ArmIK(world.scenario.robot)
        self.kin = ArmKinematics()
        self.driver = ArmDriver(world.model, world.data, world.step, world.scenario.robot,
                                kinematics=self.kin)
        self.joint_noise, self.rng = float(joint_noise), rng
        q = self.driver.joint_positions()
        self.T_flange_tcp = invert(self.kin.pose(q, "flange")) @ self.kin.pose(q, "tcp")
        self.hub: np.ndarray | None = None  # joint angles every view is reached from (rad)

    def read_joints(self) -> np.ndarray:
        """The joint readings (6,) rad: the true angles plus N(0, joint_noise^2) each."""
        q = self.driver.joint_positions()
        return q + self.rng.normal(0.0, self.joint_noise, q.shape) if self.joint_noise > 0 else q

    def path_clear(self, q0: np.ndarray, q1: np.ndarray) -> bool:
        """True when every sample of the straight joint path keeps ``_CLEARANCE`` (m)."""
        return all(self.ik.collides(q0 + s * (q1 - q0), clearance=_CLEARANCE) is None
                   for s in np.linspace(0.0, 1.0, _PATH_SAMPLES))

    def hold_and_look(self, camera: str) -> tuple[np.ndarray, np.ndarray]:
        """Hold still, then (the camera's RGB image, the joint readings) at one instant."""
        self.driver.wait(_HOLD)
        mujoco.mj_forward(self.world.model, self.world.data)  # the picture shows the joints read
        image = self.world.render(camera, depth=False, seg=False).rgb
        return image, self.read_joints()


def solve_flange_pose(ik: ArmIK, T_base_tcp: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """Joint angles (6,) rad putting the TCP at ``T_base_tcp`` (4x4, m, any orientation),
    by ``ArmIK``'s tasks and limits from ``seed``; ``IKError`` when it does not converge to
    ``ik_tolerance`` (m, and 10x that in rad) within 300 iterations."""
    return ik.solve_pose(T_base_tcp, seed, tolerance=ik.settings.ik_tolerance,
                         iterations=_IK_ITERATIONS, what="view pose")


def _survey_pose(rig: Rig, settings: object) -> np.ndarray:
    """Joint angles of a straight-down view over the board at mid distance (the hub every
    view is reached from)."""
    centre = np.asarray(settings.board_position, dtype=np.float64)
    eye = centre + np.array([0.0, 0.0, float(np.mean(settings.distance))])
    T_base_flange = look_at(eye, centre) @ invert(make_transform(np.eye(3), settings.camera_offset))
    try:
        return solve_flange_pose(rig.ik, T_base_flange @ rig.T_flange_tcp, HOME)
    except IKError as exc:
        raise CalibrationError(f"calibration: the arm cannot look straight down at the board at "
                               f"{centre.tolist()} m (calibration.board_position): {exc}") from None


def reach_view(rig: Rig, plan: ViewPlan, q_hub: np.ndarray) -> np.ndarray | str:
    """Joint angles of ``plan`` (collision-checked, seeded from ``q_hub``), or why not:
    ``'unreachable'`` (no IK solution) or ``'blocked'`` (too near the cell, on the way too)."""
    try:
        q = solve_flange_pose(rig.ik, plan.T_base_flange @ rig.T_flange_tcp, q_hub)
    except IKError:
        return "unreachable"
    if rig.ik.collides(q, clearance=_CLEARANCE) is not None or not rig.path_clear(q_hub, q):
        return "blocked"
    return q


def move_via_hub(rig: Rig, q: np.ndarray, q_hub: np.ndarray) -> None:
    """Drive to ``q``: straight when that path is clear, else through the hub pose."""
    here = rig.driver.joint_positions()
    if not rig.path_clear(here, q):
        rig.driver.move(q_hub, what="calibration hub pose")
    rig.driver.move(q, what="calibration view")


def capture_views(rig: Rig, settings: object, *, camera: str = "wrist",
                  progress: Progress | None = None) -> Capture:
    """Capture ``settings.poses`` views of the board with the arm's ``camera``.

    Planned poses that IK cannot reach or that come within 10 mm of the cell are skipped,
    counted and replaced by the next planned ones (at most 4x ``poses`` plans). ``progress``
    is called as ``progress(done, total, note)`` after each view.
    """
    want = int(settings.poses)
    q_hub = rig.hub = _survey_pose(rig, settings)
    rig.driver.sync()
    move_via_hub(rig, q_hub, q_hub)
    views: list[CapturedView] = []
    skipped = {"unreachable": 0, "blocked": 0}
    planned = 0
    while len(views) < want and planned < 4 * want:
        plan = plan_views(settings, rig.rng, count=1, start=planned)[0]
        planned += 1
        q = reach_view(rig, plan, q_hub)
        if isinstance(q, str):
            skipped[q] += 1
            continue
        try:
            move_via_hub(rig, q, q_hub)
        except MotionError:
            skipped["blocked"] += 1
            rig.driver.sync()
            continue
        image, q_read = rig.hold_and_look(camera)
        views.append(CapturedView(image, q_read, rig.kin.pose(q_read, "flange"), plan))
        if progress is not None:
            progress(len(views), want, f"tilt {plan.tilt_deg:4.1f} deg, roll {plan.roll_deg:+5.1f} deg")
    if len(views) < 3:
        raise CalibrationError(f"calibration: only {len(views)} of {planned} planned views were "
                               f"reachable ({skipped['unreachable']} unreachable, {skipped['blocked']} "
                               "too near the cell): check calibration.board_position and distance")
    return Capture(camera, tuple(views), skipped["unreachable"], skipped["blocked"])
