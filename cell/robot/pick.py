"""Pick and place with the suction tool: approach, descend, grasp, verify, lift,
transfer above the bin, release, retreat to ``HOME``.

Input is what the vision (or, in the pick benchmark, the simulator's ground truth)
says about a part: its kind, where its frame is on the table (x, y world metres: the
centroid of its silhouette) and its yaw (rad). The tool points down; its yaw is the
part's yaw turned by a multiple of the part's symmetry (catalogue ``symmetry``, 0 =
continuous) and of the cup's ring of eight lip segments, chosen so the wrist turns
the least. Every motion is a time-optimal
straight joint segment (``trajectory``) between IK solutions (``ik``).
``IKError``/``MotionError`` name the part and the reason; the arm is back at
``HOME`` (or as near as it could get) when they are raised, so a caller catches one
per part and goes on.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass, field

import mujoco
import numpy as np

from cell.catalogue import KINDS
from cell.errors import GraspError, MotionError, RobotError
from cell.robot._checks import finite
from cell.robot.ik import ArmIK, tool_yaw
from cell.robot.kinematics import ArmKinematics
from cell.robot.motion import ArmDriver
from cell.robot.settings import RobotSettings
from cell.robot.suction import SuctionCup
from cell.robot.trajectory import min_time
from cell.sim import layout
from cell.sim.arm import HOME

__all__ = ["GRASP_POINTS", "PartTarget", "PickPlace", "PickResult", "choose_tool_yaw"]

# Where the cup goes on each kind: (dx, dy) in the part frame from its silhouette
# centroid, and the height of that spot above the surface the part lies on (metres).
# The L bracket's centroid lies 1.3 mm from an edge of its long leg: the cup goes to
# that leg's centre line. The bolt lies on its side: the cup sits on the 6 mm shaft.
GRASP_POINTS: dict[str, tuple[float, float, float]] = {
    "washer": (0.0, 0.0, KINDS["washer"].height),
    "hex_nut": (0.0, 0.0, KINDS["hex_nut"].height),
    "square_nut": (0.0, 0.0, KINDS["square_nut"].height),
    "bolt": (0.0, 0.0, KINDS["bolt"].height / 2 + 0.003),
    "l_bracket": (0.0, -0.004655, KINDS["l_bracket"].height),
    "disc": (0.0, 0.0, KINDS["disc"].height),
}
TOOL_SYMMETRY = 8  # the cup's lip is a ring of eight: it grasps the same turned by 45 deg
_HOVER = 0.0  # the cup face stops at the part's nominal top; the vacuum pulls the part
# up against the lip (the lip's reach is 2 mm), so the arm never pushes on it
_SAMPLES = 12  # configurations checked for collisions along each free-space segment
_MEET_ROUNDS = 3  # predictions of a moving part's meeting point (each re-plans once)
_MEET_MARGIN = 0.06  # s: the servos' settling at the grasp, beyond the time-optimal motion


def choose_tool_yaw(part_yaw: float, symmetry: int, natural_yaw: float, *,
                    tool_symmetry: int = TOOL_SYMMETRY) -> float:
    """The tool yaw (rad) nearest to ``natural_yaw`` (the yaw reached without turning
    the wrist) among those that give the same grasp of a part at ``part_yaw``.

    The part looks the same turned by multiples of 2 pi / ``symmetry`` (0: continuous)
    and the tool by multiples of 2 pi / ``tool_symmetry`` (the suction cup's ring of
    lip segments; 0: a round cup), so the equivalent yaws are ``part_yaw`` plus the
    multiples of 2 pi / lcm(symmetry, tool_symmetry).
    """
    part_yaw = finite("part_yaw", part_yaw, RobotError)
    natural_yaw = finite("natural_yaw", natural_yaw, RobotError)
    for name, order in (("symmetry", symmetry), ("tool_symmetry", tool_symmetry)):
        if not isinstance(order, numbers.Integral) or isinstance(order, bool) or order < 0:
            raise RobotError(f"argument {name!r}: expected a whole number >= 0 (0: continuous), "
                              f"got {order!r}")
    if symmetry == 0 or tool_symmetry == 0:
        return float(natural_yaw)
    step = 2 * np.pi / math.lcm(symmetry, tool_symmetry)
    k = np.round((natural_yaw - part_yaw) / step)
    return float(part_yaw + k * step)


@dataclass(frozen=True)
class PartTarget:
    """A part to pick: ``kind`` (catalogue name), its frame at (``x``, ``y``) world
    metres with heading ``yaw`` rad, lying on a surface at height ``surface_z`` (m),
    going to ``bin`` (a key of ``layout.BINS``). A part on a running belt moves at ``vx``
    (m/s along +x) and was at (``x``, ``y``) at time ``seen_at`` (s): the pick aims where
    it will be when the cup reaches it."""

    kind: str
    x: float
    y: float
    yaw: float
    bin: str
    surface_z: float = layout.BELT_TOP
    vx: float = 0.0
    seen_at: float = 0.0

    def __post_init__(self) -> None:
        for name in ("kind", "bin"):
            if not isinstance(getattr(self, name), str):
                raise RobotError(f"PartTarget: argument {name!r}: expected a name (text), got "
                                 f"{getattr(self, name)!r}")
        for name in ("x", "y", "yaw", "surface_z", "vx", "seen_at"):
            try:
                finite(name, getattr(self, name), RobotError)
            except RobotError as exc:
                raise RobotError(f"PartTarget ({self.kind!r}): {exc}") from None

    def at(self, t: float) -> PartTarget:
        """Where the part will be at time ``t`` (s) if it rides the belt at ``vx`` (m/s along
        +x) from (``x``, ``y``) where it was seen at ``seen_at`` (s)."""
        if self.vx == 0.0:
            return self
        return dataclasses.replace(self, x=self.x + self.vx * (t - self.seen_at), seen_at=t)


@dataclass(frozen=True)
class PickResult:
    """What one pick-and-place did: ``cycle_time`` (simulated s, HOME to HOME),
    ``bound_time`` (s, the time-optimal time of the same joint segments under the same
    limits), ``ik_times`` (wall s per IK solve), ``ik_iterations`` per solve."""

    cycle_time: float
    bound_time: float
    ik_times: tuple[float, ...]
    ik_iterations: tuple[int, ...]
    waypoints: dict[str, np.ndarray] = field(repr=False)


class PickPlace:
    """The pick-and-place skill on a simulated cell (``model``, ``data``, ``step``).

    Create it once per world (it builds its IK model and pinocchio model) with the arm
    at ``HOME``; call :meth:`run` per part.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, step: Callable[[int], None],
                 settings: RobotSettings | None = None, *, log: list | None = None) -> None:
        self.settings = settings or RobotSettings()
        self.ik = ArmIK(self.settings)
        self.driver = ArmDriver(model, data, step, self.settings,
                                kinematics=ArmKinematics(), log=log)
        self.cup = SuctionCup(model, data, seal_force=self.settings.seal_force)
        self.data = data
        self.home = HOME.copy()
        self._seeds: dict[str, np.ndarray] = {}
        self._arrival = 0.0

    # --- planning -------------------------------------------------------------------
    def _solve(self, key: str, position: np.ndarray, yaw: float | None, q_ref: np.ndarray,
               what: str, *, base: np.ndarray | None = None) -> np.ndarray:
        """IK seeded from the last solution for ``key`` (else ``base``, else ``q_ref``)
        turned towards the target. ``yaw`` None: the yaw ``q_ref`` reaches with the wrist
        still, and the seed's wrist on ``q_ref``'s turn."""
        if yaw is None:  # tool down: yaw = q1 - q6 + const, so the base's turn alone
            yaw = tool_yaw(self.ik.fk(q_ref)[1]) + self.ik.base_turn(q_ref, position)
        start = self._seeds.get(key, q_ref if base is None else base)
        seed = self.ik.seed_towards(position, yaw, start)
        turns = np.round((q_ref[5] - seed[5]) / (2 * np.pi))
        if abs(seed[5] + 2 * np.pi * turns) <= 2 * np.pi:
            seed[5] += 2 * np.pi * turns  # same tool yaw, the wrist on q_ref's turn
        q = self.ik.solve(position, yaw, seed, what=what)
        self._seeds[key] = q
        return q

    def _home_near(self, q: np.ndarray) -> np.ndarray:
        """HOME with the wrist at the 45-degree step (the cup's symmetry) nearest to
        ``q``'s: the wrist barely turns on the way back and never drifts to its limit."""
        home = self.home.copy()
        step = 2 * np.pi / TOOL_SYMMETRY
        home[5] += step * np.round((q[5] - home[5]) / step)
        return home

    def _check_path(self, q0: np.ndarray, q1: np.ndarray, clearance: float, what: str) -> None:
        for s in np.linspace(0.0, 1.0, _SAMPLES):
            hit = self.ik.collides(q0 + s * (q1 - q0), clearance=clearance)
            if hit is not None:
                raise MotionError(f"{what}: the straight joint path passes within "
                                  f"{clearance * 1000:.0f} mm of the cell ({hit})")

    def plan(self, part: PartTarget) -> dict[str, np.ndarray]:
        """Joint waypoints (rad) of one cycle: above, grasp, above_bin (and home)."""
        if part.kind not in GRASP_POINTS:
            raise RobotError(f"no grasp known for kind {part.kind!r}; valid: {', '.join(GRASP_POINTS)}")
        if part.bin not in layout.BINS:
            raise RobotError(f"unknown bin {part.bin!r}; valid: {', '.join(layout.BINS)}")
        name = f"{part.kind} at ({part.x:.3f}, {part.y:.3f}) m"
        dx, dy, top = GRASP_POINTS[part.kind]
        c, s = np.cos(part.yaw), np.sin(part.yaw)
        grasp = np.array([part.x + c * dx - s * dy, part.y + s * dx + c * dy,
                          part.surface_z + top + _HOVER])
        start = self.driver.q_cmd.copy()
        still = tool_yaw(self.ik.fk(start)[1]) + self.ik.base_turn(start, grasp)  # wrist still
        yaw = choose_tool_yaw(part.yaw, KINDS[part.kind].symmetry, still)
        above = grasp + [0.0, 0.0, self.settings.approach_height]
        q_above = self._solve("above", above, yaw, start, f"approach above {name}")
        q_grasp = self.ik.solve(grasp, yaw, q_above, what=f"grasp of {name}")
        height = KINDS[part.kind].height
        drop = layout.BINS[part.bin] + [0.0, 0.0, layout.BIN_SIZE[2] +
                                        self.settings.release_height + height]
        # seeded from HOME: the base turns to the bin through HOME's side, away from the
        # conveyor and the overhead camera
        q_bin = self._solve(f"bin_{part.bin}", drop, None, q_above,
                            f"bin '{part.bin}' for {name}", base=self.home)
        home = self._home_near(q_bin)
        self._check_path(start, q_above, 0.005, f"approach to {name}")
        self._check_path(q_above, q_bin, height + 0.005, f"transfer of {name}")
        self._check_path(q_bin, home, 0.005, f"retreat from bin '{part.bin}'")
        return {"start": start, "above": q_above, "grasp": q_grasp, "bin": q_bin, "home": home}

    def _plan_to_meet(self, part: PartTarget) -> dict[str, np.ndarray]:
        """The plan for a part on a running belt: aimed where the part will be when the cup
        reaches it (the time-optimal times of the approach and the descent, plus
        ``_MEET_MARGIN``), refined over ``_MEET_ROUNDS`` predictions."""
        d = self.driver
        self._arrival = self.data.time
        for _ in range(_MEET_ROUNDS):
            wp = self.plan(part.at(self._arrival))
            reach = (min_time(wp["start"], wp["above"], d.vmax, d.amax)
                     + min_time(wp["above"], wp["grasp"], d.vmax, d.amax))
            self._arrival = self.data.time + reach + _MEET_MARGIN
        return self.plan(part.at(self._arrival))

    # --- execution ------------------------------------------------------------------
    def _execute(self, part: PartTarget, wp: dict[str, np.ndarray], name: str,
                 lifted: Callable[[], None] | None) -> list:
        """Drive one planned cycle (``lifted()`` once the part is held off the belt);
        returns the executed segments."""
        d = self.driver
        via = self.settings.via_tolerance
        # over a part riding on the belt the cup does not wait to settle: the part would
        # slide away under it
        segs = [d.move(wp["above"], what=f"approach above {name}", tolerance=via),
                d.move(wp["grasp"], what=f"grasp of {name}", tolerance=via if part.vx else None)]
        self.cup.on()
        self._wait_for(self.cup.sealed, self.settings.grasp_timeout)
        segs.append(d.move(wp["above"], what=f"lift of {name}", tolerance=via))
        if not self.cup.sealed():  # verify: the vacuum switch must report a held part
            raise GraspError(f"grasp of {name} failed: the vacuum switch reads "
                             f"{self.cup.reading():.2f} N after the lift, no part held")
        if lifted is not None:
            lifted()
        segs.append(d.move(wp["bin"], what=f"transfer of {name}", tolerance=via))
        if not self.cup.sealed():
            raise GraspError(f"{name} was lost during the transfer to bin '{part.bin}'", lost=True)
        self.cup.off()
        self._wait_for(lambda: self.cup.reading() < 0.01, self.settings.release_time + 0.2)
        self.driver.wait(self.settings.release_time)
        held = self.cup.reading()
        if held >= self.cup.seal_force:  # vented, yet a part still presses on the cup
            raise GraspError(f"{name} stayed on the cup when it was vented over bin "
                             f"'{part.bin}': the vacuum switch still reads {held:.2f} N "
                             f"(jammed on the tool)", lost=True)
        segs.append(d.move(wp["home"], what="home", tolerance=via))
        return segs

    def _wait_for(self, condition: Callable[[], bool], timeout: float) -> bool:
        for _ in range(int(np.ceil(timeout / self.driver.dt))):
            if condition():
                return True
            self.driver.wait(self.driver.dt)
        return condition()

    def _abort(self, error: MotionError) -> MotionError:
        """Vent the cup and take the arm home (as near as it gets); returns ``error``, whose
        message also says so when the arm could not get home."""
        self.cup.off()
        home = self.home.copy()
        home[5] = self.driver.q_cmd[5]
        try:
            self.driver.move(home, what="home after an aborted pick")
        except MotionError as exc:
            error.args = (f"{error}; the arm did not get back home either ({exc})", *error.args[1:])
        return error

    def run(self, part: PartTarget, *, lifted: Callable[[], None] | None = None) -> PickResult:
        """Pick ``part`` and place it in its bin; returns a :class:`PickResult`. ``lifted``,
        when given, is called once the part is held above the belt (the sort job gives the
        conveyor its go-ahead there).

        Raises ``IKError`` (no solution, nothing moved), ``GraspError`` (the vacuum switch
        reports no part after the lift, or lost on the way; ``lost`` says which) or
        ``MotionError`` (the arm blocked); after either the cup is vented and the arm taken
        home (where it cannot get there, the error's message says so too)."""
        t0 = self.data.time
        n_ik = len(self.ik.stats)
        self.driver.sync()
        wp = self._plan_to_meet(part) if part.vx else self.plan(part)
        part = part.at(self._arrival)
        name = f"{part.kind} at ({part.x:.3f}, {part.y:.3f}) m"
        try:
            segs = self._execute(part, wp, name, lifted)
        except MotionError as exc:
            raise self._abort(exc) from None
        d = self.driver
        bound = sum(min_time(s.q0, s.q1, d.vmax, d.amax) for s in segs)
        stats = self.ik.stats[n_ik:]
        return PickResult(
            cycle_time=float(self.data.time - t0),
            bound_time=float(bound),
            ik_times=tuple(t for t, _ in stats),
            ik_iterations=tuple(i for _, i in stats),
            waypoints=wp,
        )
