"""One seed makes one run; the world's parts follow the scenario; misuse is a SimError."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from cell.catalogue import MATERIALS
from cell.errors import SimError
from cell.jobs.settings import FaultSettings
from cell.scenario import scenario_from_dict
from cell.sim.faults import DROP_AFTER, FaultInjector
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


def test_a_fault_span_is_start_and_duration():
    """``blackout = [10.4, 1.0]`` darkens 10.4 s to 11.4 s (not 1.0 s to 10.4 s, nor never)."""
    model = mujoco.MjModel.from_xml_string("<mujoco/>")
    faults = FaultInjector(model, mujoco.MjData(model),
                           FaultSettings(blackout=(10.4, 1.0), conveyor_stop=(0.2, 1.8)))
    assert [faults.camera_dark(t) for t in (0.5, 10.3, 10.4, 11.0, 11.39, 11.4)] == [
        False, False, True, True, True, False]
    assert [faults.belt_stopped(t) for t in (0.1, 0.2, 1.9, 2.0)] == [False, True, True, False]
    assert not FaultInjector(model, mujoco.MjData(model), FaultSettings()).camera_dark(0.0)


def test_a_drop_grasp_loses_its_part_drop_after_metres_from_where_it_sealed(world_factory):
    world = world_factory(arm=True, parts={"count": 1})
    model, data = world.model, world.data
    act, tcp = model.actuator("arm/suction").id, model.site("arm/tcp").id
    gain = float(model.actuator_gainprm[act, 0])
    faults = FaultInjector(model, data, FaultSettings(drop=(2,)))

    def step(open_: bool, dx: float = 0.0) -> bool:  # True while the vacuum holds
        data.ctrl[act] = 1.0 if open_ else 0.0
        data.site_xpos[tcp] = [0.1 + dx, 0.4, 0.3]
        faults.step()
        return bool(model.actuator_gainprm[act, 0] == gain)

    assert step(True) and step(True, 0.5) and step(False)  # grasp 1 holds all the way
    assert step(True) and step(True, 0.6 * DROP_AFTER) and step(True, 0.95 * DROP_AFTER)
    assert not step(True, 1.05 * DROP_AFTER)  # grasp 2 lets go past DROP_AFTER
    assert faults.grasps == 2 and DROP_AFTER == 0.15


def test_place_of_tells_a_bin_from_the_table_just_beside_it(world_factory):
    """GROUND TRUTH for scoring: a part inside the metal bin is ``metal``; one on the table
    4 cm past the bin's inner edge (bins are 16 cm inside) is ``elsewhere``; on the belt, ``belt``."""
    from cell.sim import layout

    world = world_factory(parts={"count": 4, "kinds": ["washer"]}, conveyor={"speed": 0.0})
    cx, cy, _ = layout.BINS["metal"]
    inside = world.place_next_part(float(cx) + 0.05, float(cy), 0.0)
    beside = world.place_next_part(float(cx) + layout.BIN_SIZE[0] / 2 + 0.04, float(cy), 0.0)
    past_y = world.place_next_part(float(cx), float(cy) - layout.BIN_SIZE[1] / 2 - 0.04, 0.0)
    on_belt = world.place_next_part(float(layout.PICK_ZONE[0]), layout.CONVEYOR_Y, 0.0)
    assert [world.place_of(p.id) for p in (inside, beside, past_y, on_belt)] == [
        "metal", "elsewhere", "elsewhere", "belt"]


def test_the_belt_encoder_counts_tenths_of_a_millimetre(world_factory):
    world = world_factory(parts={"count": 1}, conveyor={"speed": 0.137, "mode": "continuous"})
    readings = []
    for _ in range(20):
        world.step(3)
        readings.append((world.belt_encoder(), world.conveyor.travel))
    for reading, travel in readings:
        assert abs(reading - travel) <= 0.5e-4 + 1e-12
        assert abs(reading / 1e-4 - round(reading / 1e-4)) < 1e-6
    assert readings[-1][0] > readings[0][0] > 0


def test_a_flipped_bolt_stands_on_its_head_and_a_bracket_on_its_edge():
    """faults.flipped: a bolt's x axis (shaft towards +x, head at -x) points up, so the head
    is underneath; an L bracket's y axis points up; other parts lie upside down. The yaw
    turns them about the vertical."""
    from cell.catalogue import KINDS
    from cell.sim.faults import flip_quat, flipped_half_height

    def axis_after(kind: str, axis: int, yaw: float = 0.0) -> np.ndarray:
        out = np.zeros(3)
        mujoco.mju_rotVecQuat(out, np.eye(3)[axis], flip_quat(kind, yaw))
        return out

    assert np.allclose(axis_after("bolt", 0), [0, 0, 1])
    assert np.allclose(axis_after("bolt", 0, yaw=1.0), [0, 0, 1])
    assert np.allclose(axis_after("l_bracket", 1), [0, 0, 1])
    assert np.allclose(axis_after("hex_nut", 2), [0, 0, -1])
    assert np.allclose(axis_after("washer", 0, yaw=np.pi / 2), [0, 1, 0], atol=1e-9)
    assert flipped_half_height("bolt") == KINDS["bolt"].length / 2
    assert flipped_half_height("l_bracket") == KINDS["l_bracket"].width / 2
    assert flipped_half_height("disc") == KINDS["disc"].height / 2
