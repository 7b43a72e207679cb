"""One seed makes one run; the world's parts follow the scenario; misuse is a SimError."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cell.catalogue import MATERIALS
from cell.errors import SimError
from cell.scenario import scenario_from_dict
from cell.sim.world import World


def _run(world_factory, seed: int):
    world = world_factory(seed=seed, parts={"count": 6}, sensor={"noise_std": 3.0, "salt_pepper": 0.01})
    assert world.run_until_part_at_pick(timeout=20)
    return world, world.render()


def test_same_seed_gives_byte_identical_images(world_factory):
    (wa, fa), (wb, fb) = _run(world_factory, 5), _run(world_factory, 5)
    assert fa.rgb.tobytes() == fb.rgb.tobytes()
    assert fa.depth.tobytes() == fb.depth.tobytes() and fa.seg.tobytes() == fb.seg.tobytes()
    assert [(p.kind, p.finish) for p in wa.parts] == [(p.kind, p.finish) for p in wb.parts]


def test_another_seed_gives_another_part_sequence(world_factory):
    a = world_factory(seed=1, parts={"count": 8})
    b = world_factory(seed=2, parts={"count": 8})
    assert [(p.kind, p.finish) for p in a.parts] != [(p.kind, p.finish) for p in b.parts]


def test_parts_come_from_the_scenario_catalogue(world_factory):
    world = world_factory(parts={"count": 30, "kinds": ["washer", "bolt"],
                                 "materials": ["brass", "plastic_grey"]})
    assert {p.kind for p in world.parts} == {"washer", "bolt"}
    assert {p.finish for p in world.parts} == {"brass", "plastic_grey"}
    for p in world.parts:
        assert p.material == MATERIALS[p.finish].material


def test_rendering_more_frames_does_not_change_the_part_sequence(world_factory):
    a = world_factory(seed=9, parts={"count": 3})
    b = world_factory(seed=9, parts={"count": 3})
    for _ in range(3):
        a.render(depth=False, seg=False)
    a.step(2000)
    b.step(2000)
    for i in (1, 2, 3):
        assert np.allclose(a.part_pose(i)[0], b.part_pose(i)[0])


def test_misuse_is_a_sim_error_naming_the_argument(world_factory):
    # (a dict for a scenario was an AttributeError; part 0 read the last part's truth; a
    # NaN placement made MuJoCo reset the whole simulation with a warning on stdout)
    with pytest.raises(SimError, match="argument 'scenario': expected a Scenario"):
        World.build({"seed": 1})
    world = world_factory(parts={"count": 2})
    for bad in (0, -1, 3, 1.0, True):
        with pytest.raises(SimError, match=r"the run's parts are 1 to 2"):
            world.part_pose(bad)
    with pytest.raises(SimError, match="x must be a finite number"):
        world.place_next_part(math.nan, 0.45, 0.0)
    assert world.spawned == 0


def test_a_world_is_a_context_manager():
    with World.build(scenario_from_dict({"parts": {"count": 1}}), arm=False) as world:
        world.render(depth=False, seg=False)
    assert world._rigs == {}


@pytest.mark.parametrize("n", [-5, 2.5, "3", float("nan"), True])
def test_step_takes_a_whole_number_of_steps(world_factory, n):
    """step(-5) did nothing without a word; step(nan), step(2.5), step('3') raised a raw
    TypeError."""
    world = world_factory(parts={"count": 1})
    with pytest.raises(SimError, match="step: n must be a whole number of physics steps"):
        world.step(n)


@pytest.mark.parametrize(("kwargs", "culprit"), [
    ({"timeout": float("nan")}, "timeout"), ({"timeout": -1.0}, "timeout"),
    ({"settle": float("nan")}, "settle"), ({"settle": float("inf")}, "settle"),
])
def test_run_until_part_at_pick_takes_finite_times(world_factory, kwargs, culprit):
    """timeout=nan never returned; settle=nan raised a raw ValueError."""
    world = world_factory(parts={"count": 1})
    with pytest.raises(SimError, match=f"run_until_part_at_pick: {culprit} must be a finite time"):
        world.run_until_part_at_pick(**kwargs)
