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
