"""The parts of a run and where each is: waiting off stage, live in the cell, caught past the
belt's end, or at rest in a bin.

Every part of a run is a body of the model from the start, floating off stage (gravity
compensated, at its own slot far from every view) until the conveyor spawns it. Once live
it moves only through gravity, contact and adhesion forces. Two events take it out of the
contact set again, parked back at its slot: its centre crossing the catch line past the
belt's end (``caught``), or its coming to rest inside a bin (``binned``, with the bin's
name). So nothing piles up, the contact set holds only the parts still in play.

The parts off stage sleep (MuJoCo's ``mjENBL_SLEEP``) and collide with nothing (their
collision bits zeroed, put back when they enter): a parked part, at rest, falls asleep
after a few steps, leaves the collision broadphase and costs the physics nearly nothing,
so a step's cost follows the parts in play, not the run's length. A part in play never
sleeps (its policy ``mjSLEEP_NEVER``: a part at rest on a stopped belt must still ride off
when the belt starts, which moves no body that could wake it). :meth:`Stage.place_of` says, for
scoring, where a part ended.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from cell.sim import layout

__all__ = ["PartInfo", "Stage", "offstage_slot"]

_OFFSTAGE = np.array([3.0, 3.0, 1.5])  # where waiting parts float, out of every view
_BIN_CHECK_EVERY = 50  # physics steps between looks for parts come to rest in a bin
# m/s: a part in a bin whose centre moves slower than this has come to rest. Its spin does
# not count: a part on the pile may rock at up to 1 rad/s for a minute and more (contact
# jitter) while going nowhere, and kept in play it would make every later step dearer
_AT_REST = 0.01
_MAY_SLEEP = mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED  # a part off stage
_NEVER_SLEEPS = mujoco.mjtSleepPolicy.mjSLEEP_NEVER  # a part in play


def offstage_slot(part_id: int) -> np.ndarray:
    """Where part ``part_id`` floats before it is spawned and after it is parked (m)."""
    return _OFFSTAGE + np.array([0.1 * (part_id % 20), 0.1 * (part_id // 20), 0.0])


@dataclass(frozen=True)
class PartInfo:
    """One part of the run: ``id`` (1-based, as in segmentation), kind, finish (a
    catalogue material name), material class (``metal``/``plastic``), colour, body id,
    and its defect (``none``: defects come with the inspection job)."""

    id: int
    kind: str
    finish: str
    material: str
    colour: str
    body_id: int
    defect: str = "none"


class Stage:
    """The bookkeeping of ``parts`` in ``model``/``data``: ``caught_ids`` (in order),
    ``binned`` (part id -> bin name) and the live (spawned, not parked) parts' bodies."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, parts: list[PartInfo]) -> None:
        self.model, self.data, self.parts = model, data, parts
        self.caught_ids: list[int] = []
        self.binned: dict[int, str] = {}
        self.live = np.zeros(0, dtype=np.int64)
        self._part_of_body = {p.body_id: p.id for p in parts}
        self._steps = 0
        self._geoms = {p.id: np.flatnonzero(model.geom_bodyid == p.body_id) for p in parts}
        self._bits = {p.id: (model.geom_contype[self._geoms[p.id]].copy(),
                             model.geom_conaffinity[self._geoms[p.id]].copy(),
                             int(model.body_contype[p.body_id]),
                             int(model.body_conaffinity[p.body_id])) for p in parts}

    def let_sleep(self) -> None:
        """Turn MuJoCo's sleeping on (once the model's poses are computed): the parts off
        stage, at rest, fall asleep after a few steps."""
        live = set(self.live.tolist())
        for p in self.parts:
            self.model.tree_sleep_policy[self.model.body_treeid[p.body_id]] = _MAY_SLEEP
            if p.body_id not in live:
                self._collide(p, False)
        self.model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP

    def enter(self, part: PartInfo) -> None:
        """``part`` is now in play (spawned): awake, and kept awake."""
        tree = self.model.body_treeid[part.body_id]
        self.model.tree_sleep_policy[tree] = _NEVER_SLEEPS
        self._collide(part, True)
        self.live = np.append(self.live, part.body_id)

    def _collide(self, part: PartInfo, on: bool) -> None:
        """Give ``part`` its collision bits back (``on``), or zero them (off stage)."""
        geom_type, geom_affinity, body_type, body_affinity = self._bits[part.id]
        geoms = self._geoms[part.id]
        self.model.geom_contype[geoms] = geom_type if on else 0
        self.model.geom_conaffinity[geoms] = geom_affinity if on else 0
        self.model.body_contype[part.body_id] = body_type if on else 0
        self.model.body_conaffinity[part.body_id] = body_affinity if on else 0

    def after_step(self) -> None:
        """After each physics step: park caught parts; every ``_BIN_CHECK_EVERY`` steps, the
        parts come to rest in a bin."""
        if not self.live.size:
            return
        self._take_out(self._caught(), into=None)
        self._steps += 1
        if self._steps % _BIN_CHECK_EVERY == 0:
            for name, centre in layout.BINS.items():
                if self.live.size:
                    self._take_out(self._at_rest_in(centre), into=name)

    def _caught(self) -> np.ndarray:
        """Mask of the live parts whose centre has crossed the catch line past the belt's end."""
        pos = self.data.xpos[self.live]
        return ((pos[:, 0] > layout.BELT_X[1])
                & (np.abs(pos[:, 1] - layout.CONVEYOR_Y) < layout.CATCH_HALF_WIDTH)
                & (pos[:, 2] < layout.BELT_TOP - layout.CATCH_DROP))

    def _at_rest_in(self, centre: np.ndarray) -> np.ndarray:
        """Mask of the live parts at rest inside the bin at ``centre``."""
        still = np.abs(self.data.cvel[self.live, 3:]).max(axis=1) < _AT_REST  # (cvel: rot, lin)
        return still & _inside_bin(self.data.xpos[self.live], centre)

    def _take_out(self, mask: np.ndarray, *, into: str | None) -> None:
        """Park the live parts of ``mask``: caught (``into`` None) or binned in ``into``."""
        if not mask.any():
            return
        for body in self.live[mask]:
            part = self.parts[self._part_of_body[int(body)] - 1]
            self.park(part)
            if into is None:
                self.caught_ids.append(part.id)
            else:
                self.binned[part.id] = into
        self.live = self.live[~mask]
        mujoco.mj_forward(self.model, self.data)  # poses and sensors show it gone

    def park(self, part: PartInfo) -> None:
        """Put ``part`` back at its off-stage slot, floating at rest."""
        jnt = self.model.body_jntadr[part.body_id]
        adr, dof = self.model.jnt_qposadr[jnt], self.model.jnt_dofadr[jnt]
        self.data.qpos[adr : adr + 3] = offstage_slot(part.id)
        self.data.qpos[adr + 3 : adr + 7] = [1, 0, 0, 0]
        self.data.qvel[dof : dof + 6] = 0
        self.data.qacc_warmstart[dof : dof + 6] = 0
        self.model.body_gravcomp[part.body_id] = 1.0
        self.model.tree_sleep_policy[self.model.body_treeid[part.body_id]] = _MAY_SLEEP
        self._collide(part, False)

    def place_of(self, part: PartInfo) -> str:
        """Where ``part`` (spawned) is: a bin's name (resting in it and parked, or inside it
        now), ``caught``, ``belt`` (on the belt) or ``elsewhere`` (the table, the floor, a
        bin's rim, the cup)."""
        if part.id in self.binned:
            return self.binned[part.id]
        if part.id in self.caught_ids:
            return "caught"
        pos = self.data.xpos[part.body_id]
        for name, centre in layout.BINS.items():
            if _inside_bin(pos[None], centre)[0]:
                return name
        on_belt = (layout.BELT_X[0] <= pos[0] <= layout.BELT_X[1]
                   and abs(pos[1] - layout.CONVEYOR_Y) <= layout.BELT_WIDTH / 2
                   and pos[2] > layout.BELT_TOP - 0.01)
        return "belt" if on_belt else "elsewhere"


def _inside_bin(pos: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Mask of the positions (N, 3) inside the bin at ``centre`` (below its rim)."""
    half = np.array(layout.BIN_SIZE[:2]) / 2
    return np.all(np.abs(pos[:, :2] - centre[:2]) <= half, axis=1) & (pos[:, 2] < layout.BIN_SIZE[2])
