"""Smoke: every scenario file builds its world and brings a part to the pick zone."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cell.scenario import load_scenario
from cell.sim.world import World

SCENARIOS = sorted(Path(__file__).parent.parent.joinpath("scenarios").glob("*.toml"))


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.name)
def test_scenario_runs_to_the_pick_zone(path):
    scenario = load_scenario(path, overrides=["parts.count=2"])
    world = World.build(scenario)
    try:
        if scenario.conveyor.mode == "index":
            assert world.run_until_part_at_pick(timeout=30)
        else:
            world.step(2000)
        frame = world.render()
        assert frame.rgb.shape == (scenario.camera.height, scenario.camera.width, 3)
        assert np.any(frame.seg > 0) or scenario.conveyor.mode != "index"
    finally:
        world.close()
