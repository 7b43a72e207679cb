"""The cell's model, built in code (``mujoco.MjSpec``) from named pieces: the table, the
conveyor, the bins, the target, the lights, the overhead camera, the arm and one free
body per part of the run, each part floating at its off-stage slot (gravity
compensated) until the conveyor spawns it. :class:`cell.sim.world.World` builds it once
per run.
"""

from __future__ import annotations

import mujoco
import numpy as np

from cell.scenario import Scenario
from cell.sim import layout
from cell.sim.arm import add_arm
from cell.sim.cameras import add_overhead_camera
from cell.sim.conveyor import add_conveyor
from cell.sim.fixtures import add_bins, add_table, add_target
from cell.sim.lighting import add_lights
from cell.sim.parts import add_part, add_part_materials
from cell.sim.stage import offstage_slot

__all__ = ["MSAA_MAX", "build_spec", "draw_sequence"]


def draw_sequence(scenario: Scenario, rng: np.random.Generator) -> list[tuple[str, str]]:
    """The run's parts in order, (kind, finish) each, drawn from the scenario's kinds and
    materials with ``rng``."""
    kinds, finishes = scenario.parts.kinds, scenario.parts.materials
    return [
        (kinds[rng.integers(len(kinds))], finishes[rng.integers(len(finishes))])
        for _ in range(scenario.parts.count)
    ]


MSAA_MAX = 16  # the most multisamples per pixel World.build takes (GL drivers may cap it)


def build_spec(
    scenario: Scenario, sequence: list[tuple[str, str]], *, arm: bool = True,
    flange_board: bool = False, msaa: int = 0,
) -> mujoco.MjSpec:
    """The cell's ``MjSpec``: furniture, lights, cameras, the arm and one body per part.

    ``flange_board`` mounts the calibration plate on the arm's tool (needs ``arm``);
    ``msaa`` sets the renderers' multisamples per pixel (``World.build``)."""
    spec = mujoco.MjSpec()
    spec.modelname = "cell"
    spec.option.timestep = layout.TIMESTEP
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10
    vis = spec.visual
    vis.global_.offwidth = max(640, scenario.camera.width)
    vis.global_.offheight = max(480, scenario.camera.height)
    vis.map.znear = 0.01
    # No multisampling by default: on the CPU (llvmpipe) renderer it costs 40 % of a
    # frame, and a part's centroid averages over hundreds of edge pixels anyway (README:
    # rendering). A calibration's corners want it (``World.build(msaa=4)``).
    vis.quality.offsamples = msaa
    add_table(spec)
    add_conveyor(spec)
    add_bins(spec)
    add_target(spec)
    add_lights(spec)
    add_overhead_camera(spec, fovy=scenario.camera.fovy)
    add_part_materials(spec)
    if arm:
        add_arm(spec, flange_board=flange_board)
    for i, (kind, finish) in enumerate(sequence, start=1):
        body = add_part(spec, f"part_{i}", kind, finish, offstage_slot(i))
        body.gravcomp = 1.0
    return spec
