"""Parts carried off the belt's end fall into the catch bin, are counted and leave the
contact set (issue #12, item 11: before, 200 parts heaped up past the end and the
simulation crawled)."""

from __future__ import annotations

import numpy as np

from cell.sim import layout


def _part_geoms(world) -> set[int]:
    bodies = {p.body_id for p in world.parts}
    return {g for g in range(world.model.ngeom) if int(world.model.geom_bodyid[g]) in bodies}


def test_parts_off_the_belts_end_are_caught_parked_and_counted(world_factory):
    n = 30
    world = world_factory(parts={"count": n, "spacing": 0.04},
                          conveyor={"speed": 0.5, "mode": "continuous"})
    part_geoms = _part_geoms(world)
    peak_contacts = 0
    for _ in range(60):  # 6 s in 0.1 s chunks: every part spawns, rides and falls off
        world.step(50)
        on_stage = 0
        for part in world.parts[: world.spawned]:
            x, _, z = world.part_pose(part.id)[0]
            if x >= 2.0:  # parked off stage
                continue
            on_stage += 1
            # Nothing lies past the belt's end: a part there is on its way down, not heaped.
            assert x <= layout.BELT_X[1] or z > layout.BELT_TOP - 0.03, f"part {part.id} heaped"
        # The contact set holds only the parts on stage: a few contacts each.
        assert world.data.ncon <= 8 * on_stage + 8
        peak_contacts = max(peak_contacts, world.data.ncon)
    assert world.spawned == n
    assert world.caught == n and sorted(world.caught_ids) == list(range(1, n + 1))
    assert world.on_stage == [] and all(world.is_caught(i) for i in range(1, n + 1))
    assert 0 < peak_contacts <= 8 * 26  # at most ~25 parts on the 1.1 m belt at 4 cm spacing
    # Caught parts float off stage, at rest and touching nothing, and stay there.
    parked = np.array([world.part_pose(i)[0] for i in range(1, n + 1)])
    assert (parked[:, 0] >= 3.0).all() and (parked[:, 2] > 1.0).all()
    world.step(250)
    assert np.allclose([world.part_pose(i)[0] for i in range(1, n + 1)], parked, atol=1e-9)
    touching = {int(g) for c in world.data.contact[: world.data.ncon] for g in (c.geom1, c.geom2)}
    assert not touching & part_geoms


def test_only_the_catch_zone_catches(world_factory):
    world = world_factory(parts={"count": 3, "kinds": ["washer"]}, conveyor={"speed": 0.0})
    in_bin = world.place_next_part(*layout.BINS["metal"][:2], 0.0)  # a sorted part
    beside = world.place_next_part(layout.BELT_X[1] + 0.05, layout.CONVEYOR_Y - 0.25, 0.0)
    past_end = world.place_next_part(layout.BELT_X[1] + 0.05, layout.CONVEYOR_Y, 0.0)
    world.step(100)
    assert world.caught_ids == [past_end.id]
    # the sorted part came to rest in its bin: recorded there and parked out of the contacts
    assert world.place_of(in_bin.id) == "metal" and world.part_pose(in_bin.id)[0][0] >= 3.0
    assert [p.id for p in world.on_stage] == [beside.id]
    assert world.place_of(beside.id) == "elsewhere" and world.part_pose(beside.id)[0][2] < 0.05
    assert world.place_of(past_end.id) == "caught"


def _asleep(world, part) -> bool:
    return bool(world.data.tree_asleep[world.model.body_treeid[part.body_id]] >= 0)


def test_parts_off_stage_sleep_and_parts_in_play_do_not(world_factory):
    """Waiting and caught parts sleep (MuJoCo's sleeping) and collide with nothing: they
    cost the physics nearly nothing, so a step's cost follows the parts in play, not the
    run's length. A part in
    play stays awake, even at rest on a belt held still, and rides off when it runs again."""
    world = world_factory(parts={"count": 6, "spacing": 0.1},
                          conveyor={"speed": 0.5, "mode": "continuous"},
                          faults={"conveyor_stop": [0.2, 1.8]})  # the belt stands 0.2-2.0 s
    m = world.model
    bits = {p.id: (m.geom_contype[m.geom_bodyid == p.body_id].copy(), int(m.body_contype[p.body_id]))
            for p in world.parts}  # (all waiting: zeroed)
    world.step(50)
    waiting = world.parts[world.spawned:]
    assert waiting and all(_asleep(world, p) for p in waiting)
    assert all(not m.geom_contype[m.geom_bodyid == p.body_id].any() for p in waiting)
    first = world.parts[0]
    assert world.spawned >= 1 and not _asleep(world, first)
    assert m.geom_contype[m.geom_bodyid == first.body_id].any() and m.body_contype[first.body_id]
    assert not bits[first.id][0].any()  # it collides now, it did not while it waited
    assert world.data.nv_awake < world.model.nv
    while world.time < 1.95:  # at rest on the held belt for over a second...
        world.step(10)
    assert not _asleep(world, first)
    x0 = world.part_pose(first.id)[0][0]
    while world.time < 2.5:  # ...and it rides off when the belt runs again
        world.step(10)
    assert world.part_pose(first.id)[0][0] > x0 + 0.1
    for _ in range(100):  # once caught past the belt's end it is parked, and sleeps again
        world.step(50)
        if world.is_caught(first.id):
            break
    world.step(50)
    assert world.is_caught(first.id) and _asleep(world, first)
    assert not m.geom_contype[m.geom_bodyid == first.body_id].any()


def test_a_part_rocking_in_its_bin_is_at_rest(world_factory):
    """A part on the pile in a bin may rock for a minute (contact jitter) while going
    nowhere: it is parked all the same, or every later step pays for it."""
    world = world_factory(parts={"count": 1, "kinds": ["bolt"]}, conveyor={"speed": 0.0})
    part = world.place_next_part(*layout.BINS["plastic"][:2], 0.0)
    jnt = world.model.body_jntadr[part.body_id]
    dof = world.model.jnt_dofadr[jnt]
    for _ in range(200):  # rocking about a horizontal axis at 0.5 rad/s, step after step
        if world.place_of(part.id) == "plastic" and world.part_pose(part.id)[0][0] >= 3.0:
            break
        world.data.qvel[dof : dof + 3] = 0.0
        world.data.qvel[dof + 3 : dof + 6] = [0.5, 0.0, 0.0]
        world.step(1)
    assert world.part_pose(part.id)[0][0] >= 3.0, "still in play"
    assert world.place_of(part.id) == "plastic" and world.on_stage == []
