"""The conveyor: a belt that carries parts by surface velocity, and its light barrier.

The belt is one box whose ``surfacevel`` moves whatever rests on it (NOTES.md: level,
no yaw drift). A rangefinder across the belt just above its surface is the light
barrier at the pick zone.

In ``index`` mode the belt stops when a part arriving breaks the barrier (after at least
5 mm of belt run with it clear: not the part the cup lifts, passing the beam again) and
stays stopped (latched) until the cell's controller gives the go-ahead
(:meth:`Conveyor.proceed`) and the barrier is clear, as an indexing conveyor's PLC does
with its robot; any break stops it while it lasts: a part slides on when the belt
stops (``v^2 / (2 mu g)``: 14 mm at 0.5 m/s, the belt's friction 0.9) and a bolt lying
across the belt rolls, so a short part can clear the barrier on its own; the belt used to
run again then and carried it out of reach. The controller reads only that sensor,
never the simulator's part positions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from cell.sim import layout

__all__ = ["BARRIER_HEIGHT", "BELT_RGBA", "Conveyor", "add_conveyor"]

BARRIER_HEIGHT = 0.0012  # the barrier's beam above the belt (m): below a washer's 2 mm
BELT_RGBA = (0.22, 0.30, 0.42, 1.0)  # blue-grey PVC belt
_RAIL = 0.006  # rail height above the belt (m)
# m of belt run with the barrier clear before a break latches the belt: a part arriving
# (the parts come a spacing apart), not the part the cup lifts passing the beam again
_ARRIVAL_RUN = 0.005


def add_conveyor(spec: mujoco.MjSpec) -> None:
    """Add the belt (geom ``belt``), its frame, side rails and the light barrier.

    The belt's material ``belt`` is what the ``back`` lighting preset turns into a light
    table. The barrier is the rangefinder sensor ``light_barrier`` on site ``barrier``.
    """
    mat = spec.add_material()
    mat.name = "belt"
    mat.rgba = list(BELT_RGBA)
    mat.specular = 0.05
    mat.shininess = 0.1
    rail_mat = spec.add_material()
    rail_mat.name = "rail"
    rail_mat.rgba = [0.55, 0.56, 0.58, 1]
    x0, x1 = layout.BELT_X
    cx, length = (x0 + x1) / 2, (x1 - x0)
    thick = 0.02
    body = spec.worldbody.add_body(name="conveyor", pos=[cx, layout.CONVEYOR_Y, 0])
    body.add_geom(
        name="belt",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[length / 2, layout.BELT_WIDTH / 2, thick / 2],
        pos=[0, 0, layout.BELT_TOP - thick / 2],
        material="belt",
        friction=[0.9, 0.01, 0.001],
        condim=4,
        # A non-zero surface velocity at compile time keeps m.flg_surfacevel on, so the
        # controller's run-time changes take effect (NOTES.md).
        surfacevel=[1e-6, 0, 0, 0, 0, 0],
    )
    body.add_geom(
        name="conveyor_frame",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[length / 2, layout.BELT_WIDTH / 2 + 0.01, (layout.BELT_TOP - thick) / 2],
        pos=[0, 0, (layout.BELT_TOP - thick) / 2],
        rgba=[0.3, 0.3, 0.32, 1],
    )
    for side in (-1, 1):
        body.add_geom(
            name=f"rail_{'left' if side > 0 else 'right'}",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[length / 2, 0.004, _RAIL / 2 + 0.005],
            pos=[0, side * (layout.BELT_WIDTH / 2 + 0.004), layout.BELT_TOP + _RAIL / 2 - 0.005],
            material="rail",
        )
    _add_catch_bin(body, cx)
    # The barrier looks across the belt (-y) from just inside the far rail.
    half = math.sqrt(0.5)
    body.add_site(
        name="barrier",
        pos=[layout.BARRIER_X - cx, layout.BELT_WIDTH / 2 - 0.001, layout.BELT_TOP + BARRIER_HEIGHT],
        quat=[half, half, 0, 0],  # site z axis -> world -y
        size=[0.002, 0, 0],
        rgba=[1, 0, 0, 0],
        group=4,
    )
    sensor = spec.add_sensor()
    sensor.name = "light_barrier"
    sensor.type = mujoco.mjtSensor.mjSENS_RANGEFINDER
    sensor.objtype = mujoco.mjtObj.mjOBJ_SITE
    sensor.objname = "barrier"
    sensor.cutoff = layout.BELT_WIDTH
    sensor.intprm[0] = 1 << int(mujoco.mjtRayDataField.mjRAYDATA_DIST)  # distance only


def _add_catch_bin(body: mujoco.MjsBody, cx: float) -> None:
    """The catch bin under the belt's end (geoms ``catch_bin_*`` of the conveyor body).

    Scenery only (no contacts): a part that falls off the end is parked off stage as soon
    as its centre drops below the catch line, above the bin's rim (``World.caught``).
    """
    sx, sy, h = layout.CATCH_BIN_SIZE
    wall = 0.006
    x0 = layout.BELT_X[1] + wall + sx / 2 - cx  # bin centre in the conveyor body's frame
    look = {"contype": 0, "conaffinity": 0, "rgba": [0.25, 0.27, 0.3, 1]}
    body.add_geom(name="catch_bin_floor", type=mujoco.mjtGeom.mjGEOM_BOX,
                  size=[sx / 2, sy / 2, wall / 2], pos=[x0, 0, wall / 2], **look)
    for i, (dx, dy) in enumerate(((1, 0), (-1, 0), (0, 1), (0, -1))):
        size = [wall / 2, sy / 2 + wall, h / 2] if dx else [sx / 2 + wall, wall / 2, h / 2]
        pos = [x0 + dx * (sx / 2 + wall / 2), dy * (sy / 2 + wall / 2), h / 2]
        body.add_geom(name=f"catch_bin_wall{i}", type=mujoco.mjtGeom.mjGEOM_BOX,
                      size=size, pos=pos, **look)


@dataclass
class Conveyor:
    """Run-time control of the belt: speed, mode and the light-barrier logic.

    ``speed`` is in m/s along +x; ``mode`` is ``index`` or ``continuous``. ``travel``
    is the belt's odometer (metres run since the start), used to space the spawns.
    """

    model: mujoco.MjModel
    speed: float
    mode: str
    travel: float = 0.0
    running: bool = True
    release: float = 0.0  # m: run on past a broken barrier until it has been clear this far
    latched: bool = False  # index mode: stopped by the barrier, waiting for proceed()
    _clear_run: float = math.inf  # m of belt run since the barrier was last broken

    def proceed(self) -> None:
        """The controller's go-ahead after a stop at the barrier: the belt runs again as
        soon as the barrier is clear (at once if it is), until the next break."""
        self.latched = False

    def release_part(self, distance: float = 0.03) -> None:
        """Run on although the barrier is broken (the PLC's release button), until it has
        been clear for ``distance`` metres of belt: a part the cell gives up on moves on."""
        self.release = float(distance)
        self.latched = False

    def __post_init__(self) -> None:
        self._belt = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, "belt")
        sensor = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, "light_barrier")
        self._adr = int(self.model.sensor_adr[sensor])
        self.model.flg_surfacevel = 1  # keep run-time surface velocities effective
        self._apply(self.speed)

    def barrier_blocked(self, data: mujoco.MjData) -> bool:
        """True while something interrupts the light barrier's beam (a sensor reading)."""
        distance = float(data.sensordata[self._adr])
        return 0.0 <= distance < layout.BELT_WIDTH - 0.002

    def _apply(self, speed: float) -> None:
        self.model.geom_surfacevel[self._belt] = np.array([speed, 0, 0, 0, 0, 0])

    def update(self, data: mujoco.MjData, dt: float, *, held: bool = False) -> None:
        """One control tick: stop or run the belt from the barrier, advance the odometer.

        ``held``: the belt stands still whatever the barrier says (a stop fault, or a
        controller's hold)."""
        blocked = self.mode == "index" and self.barrier_blocked(data)
        if blocked and self._clear_run >= _ARRIVAL_RUN and self.release <= 0.0:
            self.latched = True  # a part arriving (not the lifted part passing the beam again)
        run = not held and (self.mode == "continuous" or self.release > 0.0
                            or not (blocked or self.latched))
        if run != self.running:
            self._apply(self.speed if run else 0.0)
            self.running = run
        if blocked:
            self._clear_run = 0.0
        elif run:
            self._clear_run += self.speed * dt
        if run:
            self.travel += self.speed * dt
            if self.release > 0.0 and not self.barrier_blocked(data):
                self.release = max(0.0, self.release - self.speed * dt)
