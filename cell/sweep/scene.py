"""A rendered scene for the frame jobs: the scenario's parts laid out in the overhead view.

:func:`render_scene` builds the cell without the arm, puts every part of the scenario on
the belt in the overhead camera's view (seeded places and headings, at least ``gap``
apart), lets them settle, and renders the camera under each capture preset
(``capture.presets``, or the scenario's ``lighting``) and the ground-truth segmentation.
It returns a :class:`Scene`: plain arrays and the parts' ground truth (for scoring only),
with the world closed, so a worker can keep a few scenes and score many settings on them.

Randomness: the places come from ``np.random.default_rng(SeedSequence(seed).spawn(3)[2])``
(the world uses the first two children), so a scene is a function of the scenario alone.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from cell.camera import CameraModel
from cell.catalogue import KINDS
from cell.scenario import Scenario
from cell.sweep.errors import SweepError

__all__ = ["PartTruth", "Scene", "belt_rows", "place_parts", "render_scene", "scene_scenario"]

_TRIES = 2000  # random places tried per part
_MARGIN = 0.9  # parts stay within this fraction of the view's half extents


@dataclass(frozen=True)
class PartTruth:
    """GROUND TRUTH, for scoring only: a part's ``id`` (as in the segmentation), ``kind``,
    ``material`` class, ``finish``, table ``position`` (x, y) in metres and ``yaw`` (rad)."""

    id: int
    kind: str
    material: str
    finish: str
    position: tuple[float, float]
    yaw: float


@dataclass(frozen=True, eq=False)
class Scene:
    """One rendered layout: ``images`` (preset -> uint8 RGB (H, W, 3), in capture order:
    the first is the outline image), ``seg`` (int32 (H, W) part ids, 0 none), the true
    ``camera`` model, the ``parts`` (ground truth), the wall time it took (``render_s``)
    and ``retakes``: further frames of the first preset, each with fresh sensor noise."""

    images: dict[str, np.ndarray]
    seg: np.ndarray
    camera: CameraModel
    parts: tuple[PartTruth, ...]
    render_s: float
    retakes: tuple[np.ndarray, ...] = ()

    @property
    def image(self) -> np.ndarray:
        """The outline (first) image."""
        return next(iter(self.images.values()))


def scene_scenario(scenario: Scenario) -> Scenario:
    """``scenario`` with what does not change a rendered scene set to defaults (its name,
    the vision, robot, calibration and sort sections) and the belt still: runs whose
    scenarios agree on this share one scene."""
    from cell.scenario import ConveyorSettings

    default = Scenario()
    return dataclasses.replace(
        scenario, name=default.name, vision=default.vision, robot=default.robot,
        calibration=default.calibration, sort=default.sort,
        conveyor=dataclasses.replace(ConveyorSettings(), speed=0.0))


def _view(scenario: Scenario) -> tuple[float, float]:
    """Half extents (x, y) of the overhead camera's view on the belt (m)."""
    from cell.sim import layout

    half_y = layout.OVERHEAD_CAMERA_HEIGHT * math.tan(math.radians(scenario.camera.fovy) / 2)
    half_x = half_y * scenario.camera.width / scenario.camera.height
    return half_x, min(half_y, layout.BELT_WIDTH / 2)


def place_parts(kinds: list[str], scenario: Scenario, rng: np.random.Generator, *,
                gap: float) -> list[tuple[float, float, float]]:
    """Seeded places (x, y in metres, world frame; yaw in radians) for parts of ``kinds``
    inside the overhead view on the belt, bounding circles at least ``gap`` (m) apart;
    ``SweepError`` when they do not fit."""
    from cell.sim import layout

    half_x, half_y = _view(scenario)
    centre = layout.PICK_ZONE
    placed: list[tuple[float, float, float, float]] = []  # x, y, yaw, radius
    for kind in kinds:
        r = KINDS[kind].half_diagonal
        room_x, room_y = _MARGIN * half_x - r, _MARGIN * half_y - r - 0.003
        for _ in range(_TRIES):
            if room_x <= 0 or room_y < 0:
                break
            x = centre[0] + rng.uniform(-room_x, room_x)
            y = centre[1] + rng.uniform(-room_y, room_y)
            if all(math.hypot(x - px, y - py) >= r + pr + gap for px, py, _, pr in placed):
                placed.append((x, y, float(rng.uniform(0.0, 2 * math.pi)), r))
                break
        else:
            room_x = -1.0
        if room_x <= 0 or room_y < 0:
            raise SweepError(f"cannot lay out {len(kinds)} parts {gap * 1e3:g} mm apart in the "
                             f"overhead view ({scenario.camera.fovy:g} deg field of view); lower "
                             "parts.count or job.gap_mm")
    return [(x, y, yaw) for x, y, yaw, _ in placed]


def belt_rows(camera: CameraModel, *, inset: float = 0.005) -> tuple[int, int]:
    """Image rows (first, last) of the belt's band, ``inset`` metres inside its edges: the
    region where foreground is scored (outside it lie the table and the rails)."""
    from cell.sim import layout

    reach = 0.5 * camera.width / camera.K[0, 0] * layout.OVERHEAD_CAMERA_HEIGHT
    xs = layout.PICK_ZONE[0] + np.linspace(-reach, reach, 21)
    half = layout.BELT_WIDTH / 2 - inset
    rows = []
    for side in (-half, half):
        pts = np.stack([xs, np.full_like(xs, layout.CONVEYOR_Y + side),
                        np.full_like(xs, layout.BELT_TOP)], axis=1)
        rows.append(camera.project(pts)[:, 1])
    a, b = sorted((rows[0], rows[1]), key=lambda r: float(r.mean()))
    first = max(0, int(math.ceil(float(a.max()))))
    last = min(camera.height - 1, int(math.floor(float(b.min()))))
    return first, last


def render_scene(scenario: Scenario, *, gap: float = 0.004, retakes: int = 0) -> Scene:
    """Render the scene of ``scenario`` (see the module docstring), its parts' bounding
    circles at least ``gap`` (m) apart, and ``retakes`` more frames of the first preset (the
    same layout with fresh sensor noise)."""
    from cell.sim.world import World

    t0 = time.perf_counter()
    # stream 2 of SeedSequence(seed) (the world uses 0, 1; the wrist calibration 2 too, the
    # overhead one 3: never in the same run as a scene of this module)
    rng = np.random.default_rng(np.random.SeedSequence(scenario.seed).spawn(3)[2])
    world = World.build(scenario, arm=False)
    try:
        places = place_parts([p.kind for p in world.parts], scenario, rng, gap=gap)
        for x, y, yaw in places:
            world.place_next_part(x, y, yaw)
        world.step(150)  # they drop 1 mm and come to rest
        presets = scenario.capture.presets or (scenario.lighting,)
        images = {}
        for preset in presets:
            if world.lighting_name != preset:
                world.set_lighting(preset)
            images[preset] = world.render("overhead", depth=False, seg=False).rgb
        again = []
        if retakes:
            world.set_lighting(presets[0])
            again = [world.render("overhead", depth=False, seg=False).rgb for _ in range(retakes)]
        seg = world.rig("overhead").render_seg(world.data)
        parts = []
        for p in world.on_stage:
            position, _ = world.part_pose(p.id)
            parts.append(PartTruth(p.id, p.kind, p.material, p.finish,
                                   (float(position[0]), float(position[1])), world.part_yaw(p.id)))
        camera = world.camera_model("overhead")
    finally:
        world.close()
    return Scene(images, seg, camera, tuple(parts), time.perf_counter() - t0, tuple(again))
