"""``World``: the whole cell built from a scenario, stepped, lit and rendered.

The model is built once in code (``mujoco.MjSpec``) from named pieces: the table, the
conveyor, the bins, the target, the lights, the cameras, the arm and one free body per
part of the run. Parts wait off stage (floating, gravity compensated) until the conveyor
spawns them upstream one after another; the model never changes during a run, so
everything holding it (renderers, IK) stays valid.

Parts that ride off the belt's end fall towards the catch bin under it. While on the belt
and falling they move only through gravity and contact forces; once a part's centre has
dropped ``layout.CATCH_DROP`` below the belt's top past the belt's end (the catch line,
above the bin's rim) it is caught: counted in ``World.caught`` and parked back at its own
off-stage slot, floating, at rest and out of reach of every other geom, for the rest of
the run; a part come to rest in a bin is parked the same way, its bin recorded
(``World.place_of``). So nothing piles up, the contact set holds only the parts still in
play, and a run's cost grows linearly with its length (:mod:`cell.sim.stage` keeps
this account).

For the overhead camera's eye-to-hand calibration, ``World.build(...,
flange_board=True, msaa=4)`` mounts a checkerboard plate on the tool
(``cell.sim.flange_board``) and renders with 4 samples per pixel; ``hold_arm(q)`` puts
the arm at joint angles ``q``, held there; ``cell.sim.board_poses`` proposes the poses.
Both options are off by default, when the model is the one built without them.

Randomness: one ``np.random.SeedSequence(scenario.seed)`` gives independent streams for
the part sequence and for the sensor noise, so rendering more or fewer frames never
changes which parts come.
"""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np

from cell.camera import CameraModel
from cell.catalogue import KINDS, MATERIALS
from cell.errors import SimError
from cell.scenario import Scenario, check_scenario
from cell.sim import layout
from cell.sim.arm import HOME, JOINT_NAMES
from cell.sim.cameras import CameraRig, Frame, true_camera_model
from cell.sim.conveyor import Conveyor
from cell.sim.faults import FaultInjector, flip_quat, flipped_half_height
from cell.sim.flange_board import corners_in_flange
from cell.sim.lighting import LightingPreset, apply_lighting
from cell.sim.sensor import SensorModel
from cell.sim.spec import MSAA_MAX, build_spec, draw_sequence
from cell.sim.stage import PartInfo, Stage
from cell.text import show

__all__ = ["CAMERAS", "PartInfo", "World"]

CAMERAS = {"overhead": "overhead", "wrist": "arm/wrist_camera"}  # user name -> model name


class World:
    """The running cell. Build it with ``World.build(scenario)``.

    Attributes: ``model``, ``data`` (MuJoCo), ``scenario``, ``parts`` (every part of the
    run, spawned or not), ``spawned`` (how many are out), ``caught_ids`` (the parts that
    fell off the belt's end into the catch bin, in order; ``caught`` counts them),
    ``conveyor`` (belt control), ``lighting`` (the active preset), ``has_arm``,
    ``has_flange_board`` (the calibration plate of ``cell.sim.flange_board`` is mounted).
    """

    def __init__(self, scenario: Scenario, *, arm: bool = True,
                 flange_board: bool = False, msaa: int = 0) -> None:
        check_scenario(scenario, "World", SimError)
        if flange_board and not arm:
            raise SimError("the flange board needs the arm: build with arm=True")
        if isinstance(msaa, bool) or not isinstance(msaa, (int, np.integer)) or \
                not 0 <= msaa <= MSAA_MAX:
            raise SimError(f"msaa must be an integer in 0..{MSAA_MAX} (multisamples per "
                           f"pixel), got {msaa!r}")
        self.scenario = scenario
        seeds = np.random.SeedSequence(scenario.seed).spawn(2)
        self.rng = np.random.default_rng(seeds[0])  # part sequence and spawn poses
        self._sensor_rng = np.random.default_rng(seeds[1])
        sequence = draw_sequence(scenario, self.rng)
        self.spec = build_spec(scenario, sequence, arm=arm, flange_board=flange_board,
                               msaa=int(msaa))
        try:
            self.model = self.spec.compile()
        except Exception as exc:  # MuJoCo raises ValueError with its compiler message
            raise SimError(f"the cell's model does not compile: {exc}") from exc
        self.data = mujoco.MjData(self.model)
        self.has_arm = arm
        self.has_flange_board = flange_board
        self.parts: list[PartInfo] = []
        for i, (kind, finish) in enumerate(sequence, start=1):
            m = MATERIALS[finish]
            bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, f"part_{i}")
            self.parts.append(PartInfo(i, kind, finish, m.material, m.colour, bid))
        self._part_of_geom = np.zeros(self.model.ngeom, dtype=np.int32)
        body_to_part = {p.body_id: p.id for p in self.parts}
        for g in range(self.model.ngeom):
            self._part_of_geom[g] = body_to_part.get(int(self.model.geom_bodyid[g]), 0)
        self.spawned = 0
        self.stage = Stage(self.model, self.data, self.parts)
        self._travel_at_spawn = -math.inf
        self.conveyor = Conveyor(self.model, scenario.conveyor.speed, scenario.conveyor.mode)
        self.faults = FaultInjector(self.model, self.data, scenario.faults)
        self.lighting: LightingPreset = apply_lighting(self.model, scenario.lighting)
        self.lighting_name = scenario.lighting
        self._rigs: dict[str, CameraRig] = {}
        if arm:
            self._arm_home()
        mujoco.mj_forward(self.model, self.data)
        self.stage.let_sleep()

    def _arm_home(self) -> None:
        """Put the arm at its home configuration, with its servos holding it there."""
        for name, q in zip(JOINT_NAMES, HOME, strict=True):
            self.data.qpos[self.model.joint(f"arm/{name}").qposadr[0]] = q
            self.data.ctrl[self.model.actuator(f"arm/{name}").id] = q

    @classmethod
    def build(cls, scenario: Scenario, *, arm: bool = True, flange_board: bool = False,
              msaa: int = 0) -> World:
        """Build the world of ``scenario``; ``arm=False`` leaves the robot out.

        ``flange_board=True`` mounts the calibration plate on the tool (eye-to-hand
        calibration; ``cell.sim.flange_board``). ``msaa`` (0..16) renders with that many
        samples per pixel (MuJoCo's ``offsamples``; the CPU renderer takes at most 4), as
        a real sensor integrates light over each pixel: a checkerboard's corners then
        come within about 0.1 px RMS of the truth instead of about 0.3 px (hard-stepped
        edges), at about 1.6 times the render time. Both off by default, when the model
        is exactly the one built without them.
        """
        return cls(scenario, arm=arm, flange_board=flange_board, msaa=msaa)

    # --- arm --------------------------------------------------------------------------
    def _require_arm(self, what: str) -> None:
        if not self.has_arm:
            raise SimError(f"{what}: this world has no arm (built with arm=False)")

    def arm_joint_positions(self) -> np.ndarray:
        """The arm's joint readings (6,) rad, shoulder_pan to wrist_3 (the encoders)."""
        self._require_arm("arm_joint_positions")
        m = self.model
        return np.array([self.data.qpos[m.joint(f"arm/{n}").qposadr[0]] for n in JOINT_NAMES])

    def hold_arm(self, q: np.ndarray) -> None:
        """Put the arm at joint angles ``q`` (6,) rad, at rest, with its servos holding it
        there (position references ``q``, velocity references and feed-forward 0), and
        update every pose, so the next render shows it there.

        A placement, not a motion: check the way there for collisions yourself (the IK's
        ``collides``). The servos and the gravity compensation hold the arm still while
        the world steps on (its joints drift by under 1e-6 rad). Raises ``SimError``
        without an arm, or for a ``q`` of the wrong shape, not finite or out of the
        joints' ranges.
        """
        self._require_arm("hold_arm")
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (len(JOINT_NAMES),) or not np.all(np.isfinite(q)):
            raise SimError(f"hold_arm: q must be {len(JOINT_NAMES)} finite joint angles (rad), "
                           f"got {np.array2string(q, precision=4)}")
        m, d = self.model, self.data
        for i, (name, qi) in enumerate(zip(JOINT_NAMES, q, strict=True)):
            jnt = m.joint(f"arm/{name}")
            lo, hi = m.jnt_range[jnt.id]
            if not lo <= qi <= hi:
                raise SimError(f"hold_arm: joint {i} ({name}) at {qi:.4f} rad is out of its "
                               f"range [{lo:.4f}, {hi:.4f}]")
            d.qpos[jnt.qposadr[0]] = qi
            d.qvel[jnt.dofadr[0]] = 0.0
            d.qacc_warmstart[jnt.dofadr[0]] = 0.0
            d.ctrl[m.actuator(f"arm/{name}").id] = qi
            d.ctrl[m.actuator(f"arm/{name}_vel").id] = 0.0
            d.ctrl[m.actuator(f"arm/{name}_ff").id] = 0.0
        mujoco.mj_forward(m, d)

    def flange_pose(self) -> np.ndarray:
        """GROUND TRUTH, for scoring only: ``T_world_flange`` (4x4, metres) now. The arm's
        base frame is the world frame (``layout.ARM_BASE`` is the origin)."""
        self._require_arm("flange_pose")
        site = self.data.site("arm/flange")
        T = np.eye(4)
        T[:3, :3] = site.xmat.reshape(3, 3)
        T[:3, 3] = site.xpos
        return T

    def flange_board_corners_world(self) -> np.ndarray:
        """GROUND TRUTH, for scoring only: the flange board's inner corners (N, 3) in the
        world now (metres), in ``cell.sim.flange_board.board_corners`` order."""
        if not self.has_flange_board:
            raise SimError("flange_board_corners_world: no flange board (build the world "
                           "with flange_board=True)")
        T = self.flange_pose()
        return corners_in_flange() @ T[:3, :3].T + T[:3, 3]

    # --- time -------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return float(self.data.time)

    @property
    def barrier_blocked(self) -> bool:
        """The light barrier's reading: True while something breaks its beam."""
        return self.conveyor.barrier_blocked(self.data)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` (an integer >= 0) physics steps, running the conveyor and spawning
        parts."""
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
            raise SimError(f"step: n must be a whole number of physics steps >= 0, got {n!r}")
        dt = self.model.opt.timestep
        spacing = self.scenario.parts.spacing
        for _ in range(n):
            self.conveyor.update(self.data, dt, held=self.faults.belt_stopped(self.data.time))
            if self.spawned < len(self.parts) and (
                self.conveyor.travel - self._travel_at_spawn >= spacing
            ) and self._room_to_spawn():
                self._spawn_upstream()
            self.faults.step()
            mujoco.mj_step(self.model, self.data)
            self.stage.after_step()

    def run_until_part_at_pick(self, timeout: float = 30.0, settle: float = 0.3) -> bool:
        """Give the belt its go-ahead (``conveyor.proceed``: index mode latches it at each
        part) and run until the light barrier is broken, then ``settle`` seconds more.

        Returns False if nothing reached the barrier within ``timeout`` simulated seconds
        (both finite, >= 0). Only meaningful in ``index`` mode (in ``continuous`` mode parts
        pass through).
        """
        for name, value in (("timeout", timeout), ("settle", settle)):
            if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating) \
                    or not 0 <= value < math.inf:
                raise SimError(f"run_until_part_at_pick: {name} must be a finite time >= 0 (s), "
                               f"got {value!r}")
        end = self.time + timeout
        self.conveyor.proceed()
        while not self.barrier_blocked:
            if self.time >= end:
                return False
            self.step(10)
        self.step(max(1, round(settle / self.model.opt.timestep)))
        return True

    # --- parts ------------------------------------------------------------------------
    @property
    def caught_ids(self) -> list[int]:
        """The parts that fell off the belt's end into the catch bin, in order."""
        return self.stage.caught_ids

    @property
    def caught(self) -> int:
        """How many parts fell off the belt's end into the catch bin (and were parked)."""
        return len(self.stage.caught_ids)

    @property
    def on_stage(self) -> list[PartInfo]:
        """The spawned parts still in the cell (not caught, not resting in a bin), in spawn order."""
        gone = set(self.stage.caught_ids) | set(self.stage.binned)
        return [p for p in self.parts[: self.spawned] if p.id not in gone]

    def is_caught(self, part_id: int) -> bool:
        """True once part ``part_id`` has fallen into the catch bin (it is parked off stage)."""
        return part_id in self.stage.caught_ids

    def place_of(self, part_id: int) -> str:
        """GROUND TRUTH, for scoring only: where part ``part_id`` is: ``waiting`` (not
        spawned yet), a bin's name (resting in it and parked, or inside it now), ``caught``
        (fell off the belt's end), ``belt`` (on the belt) or ``elsewhere`` (the table, the
        floor, a bin's rim, the cup)."""
        part = self._part(part_id)
        if part_id > self.spawned:
            return "waiting"
        return self.stage.place_of(part)

    def belt_encoder(self) -> float:
        """The belt's encoder: metres run since the start, in 0.1 mm counts."""
        return round(self.conveyor.travel / 1e-4) * 1e-4

    def _room_to_spawn(self) -> bool:
        """Whether the next part, dropped at the spawn point, clears the last one: their
        circles round the footprints apart by 1 mm (at 4-5 cm spacing two brackets, 50 mm
        across, were dropped 2 mm into each other and settled on top, tilted)."""
        if self.spawned == 0:
            return True
        last, nxt = self.parts[self.spawned - 1], self.parts[self.spawned]
        reach = sum(math.hypot(KINDS[p.kind].length, KINDS[p.kind].width) / 2 for p in (last, nxt))
        return self.data.xpos[last.body_id][0] - layout.SPAWN_X >= reach + 0.001

    def _spawn_upstream(self) -> None:
        lateral = self.scenario.parts.lateral_range
        y = layout.CONVEYOR_Y + self.rng.uniform(-lateral, lateral)
        yaw = self.rng.uniform(0.0, 2 * math.pi)
        pair = self.spawned + 2 <= len(self.parts) and self.faults.touches_previous(self.spawned + 2)
        if pair:  # the next part is spawned against this one: both lie along the belt
            yaw = 0.0
        x = layout.SPAWN_X
        spawned = [self.place_next_part(x, y, yaw)]
        if pair:
            first, second = self.parts[self.spawned - 1], self.parts[self.spawned]
            x -= (KINDS[first.kind].length + KINDS[second.kind].length) / 2
            spawned.append(self.place_next_part(x, y, 0.0))
        v = self.conveyor.speed if self.conveyor.running else 0.0
        for part in spawned:
            self._set_velocity(part, [v, 0, 0])
        self._travel_at_spawn = self.conveyor.travel

    def place_next_part(self, x: float, y: float, yaw: float) -> PartInfo:
        """Put the next waiting part at rest at (x, y) (world, metres) with yaw (rad).

        It is dropped from 1 mm above the surface under it (belt or table); a part put
        past the belt's end below the catch line is caught at the next step. Raises
        SimError when every part of the run is already out.
        """
        if self.spawned >= len(self.parts):
            raise SimError(f"all {len(self.parts)} parts of the run are already spawned")
        for name, value in (("x", x), ("y", y), ("yaw", yaw)):
            if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating) \
                    or not math.isfinite(value) or abs(value) > 1e3:
                raise SimError(f"place_next_part: {name} must be a finite number within 1000 "
                               f"(m, rad), got {value!r}")
        part = self.parts[self.spawned]
        self.spawned += 1
        on_belt = abs(y - layout.CONVEYOR_Y) < layout.BELT_WIDTH / 2 and (
            layout.BELT_X[0] <= x <= layout.BELT_X[1]
        )
        quat = [math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)]
        half = KINDS[part.kind].height / 2
        if self.faults.is_flipped(part.id):  # the [faults] section's flipped parts
            quat, half = flip_quat(part.kind, yaw), flipped_half_height(part.kind)
        z = (layout.BELT_TOP if on_belt else 0.0) + half + 0.001
        jnt = self.model.body_jntadr[part.body_id]
        adr = self.model.jnt_qposadr[jnt]
        self.data.qpos[adr : adr + 3] = [x, y, z]
        self.data.qpos[adr + 3 : adr + 7] = quat
        self._set_velocity(part, [0, 0, 0])
        self.model.body_gravcomp[part.body_id] = 0.0
        self.stage.enter(part)
        mujoco.mj_forward(self.model, self.data)
        return part

    def _set_velocity(self, part: PartInfo, v: list[float]) -> None:
        dof = self.model.jnt_dofadr[self.model.body_jntadr[part.body_id]]
        self.data.qvel[dof : dof + 6] = [*v, 0, 0, 0]

    def part_pose(self, part_id: int) -> tuple[np.ndarray, np.ndarray]:
        """GROUND TRUTH, for scoring only: position (3,) metres and quaternion wxyz (4,). A
        part out of play (waiting, binned and at rest, caught: see :meth:`place_of`) is
        parked off stage, metres from the cell: its pose is the parking spot's."""
        body = self._part(part_id).body_id
        return self.data.xpos[body].copy(), self.data.xquat[body].copy()

    def part_yaw(self, part_id: int) -> float:
        """GROUND TRUTH, for scoring only: heading of the part's x axis (rad, -pi..pi; not
        folded by the kind's symmetry)."""
        R = self.data.xmat[self._part(part_id).body_id].reshape(3, 3)
        return math.atan2(R[1, 0], R[0, 0])

    def _part(self, part_id: int) -> PartInfo:
        """Part ``part_id`` (1..len(parts)); a ``SimError`` naming the valid ids otherwise (an
        id of 0 or below read another part's truth, counted from the end)."""
        if isinstance(part_id, bool) or not isinstance(part_id, int | np.integer) \
                or not 1 <= part_id <= len(self.parts):
            raise SimError(f"part id {part_id!r}: the run's parts are 1 to {len(self.parts)}")
        return self.parts[int(part_id) - 1]

    # --- light and cameras ------------------------------------------------------------
    def set_lighting(self, name: str) -> None:
        """Switch to lighting preset ``name`` (no recompile; next render uses it)."""
        self.lighting = apply_lighting(self.model, name)
        self.lighting_name = name

    def _camera_name(self, camera: str) -> str:
        valid = [c for c in CAMERAS if c == "overhead" or self.has_arm]
        if camera not in valid:
            raise SimError(f"unknown camera {show(camera)}; valid: {', '.join(valid)}")
        return CAMERAS[camera]

    def rig(self, camera: str) -> CameraRig:
        """The renderer of ``camera`` (made on first use): raw RGB, depth, segmentation."""
        if camera not in self._rigs:
            cam, s = self.scenario.camera, self.scenario.sensor
            sensor = SensorModel(
                K=self.camera_model(camera).K, width=cam.width, height=cam.height,
                noise_std=s.noise_std, salt_pepper=s.salt_pepper, distortion=s.distortion,
                bits=s.bits,
            )
            self._rigs[camera] = CameraRig(
                self.model, self._camera_name(camera), sensor, self._part_of_geom
            )
        return self._rigs[camera]

    def camera_model(self, camera: str = "overhead") -> CameraModel:
        """The true camera model (intrinsics, distortion, pose) of ``camera`` now."""
        cam = self.scenario.camera
        return true_camera_model(self.model, self.data, self._camera_name(camera), cam.width, cam.height,
                                 self.scenario.sensor.distortion)

    def render(self, camera: str = "overhead", *, depth: bool = True, seg: bool = True) -> Frame:
        """Render ``camera``: the sensor's RGB, and depth and segmentation if asked."""
        rig = self.rig(camera)
        rgb = rig.sensor.apply(rig.render_rgb(self.data), self._sensor_rng, gain=self.lighting.gain)
        if self.faults.camera_dark(self.time):  # a blackout fault: the sensor delivers black
            rgb = np.zeros_like(rgb)
        h, w = rgb.shape[:2]
        d = rig.render_depth(self.data) if depth else np.zeros((h, w), np.float32)
        s = rig.render_seg(self.data) if seg else np.zeros((h, w), np.int32)
        return Frame(rgb=rgb, depth=d, seg=s, camera=self.camera_model(camera))

    def save_xml(self, path: str | Path) -> None:
        """Write the compiled model as MJCF for inspection, whole or not at all
        (``SimError`` naming the path when it cannot be written)."""
        from cell.files import atomic_write_text

        atomic_write_text(path, self.spec.to_xml(), kind="model XML", error=SimError)

    def close(self) -> None:
        """Free the renderers' GL contexts."""
        for rig in self._rigs.values():
            rig.close()
        self._rigs.clear()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()
