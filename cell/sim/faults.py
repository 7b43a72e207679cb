"""Faults of the simulated cell, injected from the scenario's ``[faults]`` section.

The world plays the hardware, so its faults live here, on the simulator's side; the job
that runs the cell never reads this module, it sees only the effects: black frames, a
belt that does not move, a vacuum that does not seal, a part that falls off the cup, a
part lying on its edge or touching its neighbour. Each fault names a time span (s of
simulated time) or a number (the Nth grasp, the Nth part):

- ``blackout``: the camera delivers black frames (``World.render``);
- ``conveyor_stop``: the belt stands still whatever its controller says;
- ``suction_fail``: the vacuum of that grasp never builds (the cup's adhesion is cut while
  its valve is open);
- ``drop``: that grasp's part falls off once the tool has carried it ``DROP_AFTER`` metres
  away from where it sealed (mid-transfer);
- ``flipped``: that part is spawned flipped (``flip_quat``);
- ``touching``: that part is spawned against the part before it (``World`` spawns it).

A grasp is counted at each opening of the vacuum valve (its control going from off to on).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from cell.catalogue import KINDS
from cell.jobs.settings import FaultSettings

__all__ = ["DROP_AFTER", "FaultInjector", "flip_quat", "flipped_half_height"]

DROP_AFTER = 0.15  # m: a ``drop`` grasp loses its part this far (xy) from where it sealed


def flip_quat(kind: str, yaw: float) -> np.ndarray:
    """The orientation (quaternion wxyz) of a flipped part of ``kind`` turned by ``yaw``
    (rad): a bolt stands on its head (its x axis up), an L bracket on the edge of its long
    leg (its y axis up), any other part lies upside down."""
    c, s = math.cos(yaw / 2), math.sin(yaw / 2)
    turn = np.array([c, 0.0, 0.0, s])
    h = math.sqrt(0.5)
    tilt = {"bolt": [h, 0.0, -h, 0.0],        # -90 deg about y: x -> z, the head down
            "l_bracket": [h, h, 0.0, 0.0]}.get(kind, [0.0, 1.0, 0.0, 0.0])  # about x
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, turn, np.array(tilt))
    return out


def flipped_half_height(kind: str) -> float:
    """Height (m) of a flipped part's frame origin above the surface it stands on."""
    k = KINDS[kind]
    return {"bolt": k.length / 2, "l_bracket": k.width / 2}.get(kind, k.height / 2)


class FaultInjector:
    """Applies ``settings`` to a world's model and data, one physics step at a time."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, settings: FaultSettings) -> None:
        self.settings = settings
        self.model, self.data = model, data
        self.grasps = 0  # vacuum openings so far
        self._valve_was_open = False
        self._sealed_at: np.ndarray | None = None
        self._act = self._tcp = None
        if model.nu and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, "arm/suction") >= 0:
            self._act = model.actuator("arm/suction").id
            self._tcp = model.site("arm/tcp").id
            self._gain = float(model.actuator_gainprm[self._act, 0])

    @staticmethod
    def _in(span: tuple[float, ...], t: float) -> bool:
        return bool(span) and span[0] <= t < span[0] + span[1]

    def camera_dark(self, t: float) -> bool:
        """Whether the camera delivers black frames at time ``t`` (s)."""
        return self._in(self.settings.blackout, t)

    def belt_stopped(self, t: float) -> bool:
        """Whether the belt is held still at time ``t`` (s)."""
        return self._in(self.settings.conveyor_stop, t)

    def is_flipped(self, part_id: int) -> bool:
        return part_id in self.settings.flipped

    def touches_previous(self, part_id: int) -> bool:
        return part_id in self.settings.touching

    def step(self) -> None:
        """Before a physics step: count grasps, cut the vacuum of a failing or dropping one."""
        if self._act is None or not (self.settings.suction_fail or self.settings.drop):
            return
        is_open = bool(self.data.ctrl[self._act] > 0.5)
        if is_open and not self._valve_was_open:
            self.grasps += 1
            self._sealed_at = None
        self._valve_was_open = is_open
        cut = False
        if is_open and self.grasps in self.settings.suction_fail:
            cut = True
        elif is_open and self.grasps in self.settings.drop:
            tcp = self.data.site_xpos[self._tcp][:2]
            if self._sealed_at is None:
                self._sealed_at = tcp.copy()
            cut = float(np.hypot(*(tcp - self._sealed_at))) > DROP_AFTER
        self.model.actuator_gainprm[self._act, 0] = 0.0 if cut else self._gain
