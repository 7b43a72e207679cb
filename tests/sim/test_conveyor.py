"""The belt carries parts at the set speed, level, and the light barrier indexes it."""

from __future__ import annotations

import numpy as np
import pytest

from cell.catalogue import KINDS
from cell.sim import layout


@pytest.mark.parametrize("kind", ["washer", "bolt", "l_bracket"])
def test_part_rides_at_belt_speed_and_stays_level(world_factory, kind):
    speed = 0.15
    world = world_factory(parts={"count": 1, "kinds": [kind]}, conveyor={"speed": speed})
    world.step(250)  # spawn and settle for 0.5 s
    p0, q0 = world.part_pose(1)
    t0 = world.time
    world.step(1000)  # 2 s
    p1, q1 = world.part_pose(1)
    measured = (p1[0] - p0[0]) / (world.time - t0)
    assert abs(measured - speed) / speed < 0.02
    assert abs(p1[1] - p0[1]) < 1e-3  # no sideways drift
    assert abs(p1[2] - p0[2]) < 1e-4  # stays on the belt surface
    assert abs(abs(np.dot(q0, q1)) - 1) < 1e-4  # no rotation on the way


def test_index_mode_stops_at_the_light_barrier(world_factory):
    world = world_factory(parts={"count": 3, "kinds": ["disc"]}, conveyor={"speed": 0.2})
    assert world.run_until_part_at_pick(timeout=20)
    assert world.barrier_blocked and not world.conveyor.running
    pos, _ = world.part_pose(1)
    leading_edge = pos[0] + KINDS["disc"].length / 2
    assert abs(leading_edge - layout.BARRIER_X) < 0.004
    world.step(500)  # one more second: nothing moves while the barrier is broken
    assert np.allclose(world.part_pose(1)[0], pos, atol=1e-4)
    assert world.part_pose(2)[0][0] < pos[0] - 0.05  # the next part waits upstream


def test_the_belt_waits_for_the_go_ahead_though_a_part_rolls_past_the_barrier(world_factory):
    """At 0.5 m/s a bolt lying across the belt rolls on when the belt stops and clears the
    barrier by itself: the belt ran again and carried it away (3 of 8 seeds). It stays
    stopped now, the part within the pick window, until ``proceed``."""
    world = world_factory(seed=25, parts={"count": 1, "kinds": ["bolt"]},
                          conveyor={"speed": 0.5})
    assert world.run_until_part_at_pick(timeout=20, settle=0.0)
    world.step(750)  # 1.5 s
    pos, _ = world.part_pose(1)
    assert not world.barrier_blocked and not world.conveyor.running  # rolled past: held
    assert layout.BARRIER_X + 0.01 < pos[0] < layout.PICK_ZONE[0] + 0.12
    world.step(250)
    assert np.allclose(world.part_pose(1)[0], pos, atol=1e-4)
    world.conveyor.proceed()
    world.step(250)
    assert world.conveyor.running and world.part_pose(1)[0][0] > pos[0] + 0.1


def test_each_run_to_the_pick_zone_gives_the_go_ahead(world_factory):
    """The second call waited with the belt latched by the first part (it rolled past the
    barrier) and returned False; it gives the go-ahead and brings the next part."""
    world = world_factory(seed=25, parts={"count": 2, "kinds": ["bolt"]},
                          conveyor={"speed": 0.5})
    assert world.run_until_part_at_pick(timeout=20, settle=1.5)
    assert not world.barrier_blocked and world.conveyor.latched
    assert world.run_until_part_at_pick(timeout=20)
    assert world.part_pose(2)[0][0] > layout.BARRIER_X - 0.05


def _scripted_beam(world_factory):
    """A 0.1 m/s indexing belt whose light barrier reads what the test says: (the conveyor,
    ``ticks(n, blocked)``, which runs n control ticks with the beam broken or clear)."""
    world = world_factory(parts={"count": 1}, conveyor={"speed": 0.1})
    belt, beam = world.conveyor, {"blocked": False}
    belt.barrier_blocked = lambda data: beam["blocked"]
    dt = world.model.opt.timestep

    def ticks(n: int, blocked: bool) -> None:
        beam["blocked"] = blocked
        for _ in range(n):
            belt.update(world.data, dt)

    return belt, ticks


def test_only_a_part_arriving_latches_the_belt(world_factory):
    """The part the cup lifts passes the beam again: a break within 5 mm of belt run after
    the barrier cleared stops the belt while it lasts but does not latch it (latching held
    the belt through the arm's transfer: fewer parts a minute); a break after a longer
    clear run, a part arriving, latches it until ``proceed``."""
    belt, ticks = _scripted_beam(world_factory)
    ticks(100, False)
    ticks(1, True)  # a part arrives
    assert belt.latched and not belt.running
    belt.proceed()
    ticks(10, True)  # the cup still on it
    assert not belt.latched and not belt.running
    ticks(1, False)  # lifted
    assert belt.running
    ticks(3, True)  # the lifted part in the beam again: 0.2 mm of run
    assert not belt.running and not belt.latched
    ticks(30, False)  # 6 mm
    assert belt.running
    ticks(1, True)  # the next part
    assert belt.latched and not belt.running
    ticks(50, False)  # it rolls past the beam: the belt waits
    assert belt.latched and not belt.running


def test_a_released_part_rides_on_until_clear_of_the_beam_for_the_set_distance(world_factory):
    """The release button (a part the cell gives up on): the belt runs through the break,
    and a break within the release's 30 mm after the beam cleared (the same part's next
    leg, a gap in its outline) neither stops nor latches it; after 30 mm clear, the next
    break is a part arriving and latches it."""
    belt, ticks = _scripted_beam(world_factory)
    ticks(100, False)
    ticks(1, True)  # the part arrives
    assert belt.latched
    belt.release_part(0.03)
    ticks(20, True)
    assert belt.running and not belt.latched
    ticks(50, False)  # 10 mm clear: past the 5 mm of an arrival's clear run
    ticks(20, True)  # the released part's second leg in the beam
    assert belt.running and not belt.latched
    ticks(150, False)  # 30 mm clear: the release is over
    ticks(1, True)
    assert belt.latched and not belt.running


def test_continuous_mode_never_stops(world_factory):
    world = world_factory(parts={"count": 1, "kinds": ["disc"]},
                          conveyor={"speed": 0.2, "mode": "continuous"})
    world.step(4500)  # 9 s: the part passes the barrier
    assert world.conveyor.running
    assert world.part_pose(1)[0][0] > layout.BARRIER_X + 0.05


def test_parts_spawn_one_after_another_with_the_set_spacing(world_factory):
    world = world_factory(parts={"count": 4, "kinds": ["washer"], "spacing": 0.12},
                          conveyor={"speed": 0.2})
    world.step(1500)
    xs = [world.part_pose(i)[0][0] for i in range(1, 5)]
    assert world.spawned == 4
    gaps = -np.diff(xs)
    assert np.allclose(gaps, 0.12, atol=0.005)


def test_parts_at_the_closest_spacing_do_not_spawn_into_each_other(world_factory):
    """At 4 cm of spacing two L brackets (50 mm across) were dropped 2 mm into each other
    and settled on top of one another, tilted 5-7 degrees: a part now waits until the
    last one is clear of the spawn point."""
    import math

    world = world_factory(seed=3, parts={"count": 8, "kinds": ["l_bracket"], "spacing": 0.04,
                                         "lateral_range": 0.0},
                          conveyor={"speed": 0.1, "mode": "continuous"})
    while world.spawned < 8:
        world.step(10)
    world.step(300)
    for part in world.on_stage:
        R = world.data.xmat[part.body_id].reshape(3, 3)
        assert math.degrees(math.acos(min(1.0, abs(R[2, 2])))) < 1.0, part.id  # lying flat
