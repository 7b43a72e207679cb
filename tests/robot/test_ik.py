"""mink IK: convergence, tool down, least wrist turn, clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from cell.errors import IKError
from cell.robot.ik import ArmIK, down_rotation, tool_yaw
from cell.robot.pick import choose_tool_yaw
from cell.sim import layout
from cell.sim.arm import HOME


@pytest.fixture(scope="module")
def ik():
    return ArmIK()


def test_reachable_targets_converge_tool_down(ik):
    rng = np.random.default_rng(3)
    for _ in range(15):
        p = layout.PICK_ZONE + [rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05),
                                rng.uniform(0.01, 0.08)]
        yaw = rng.uniform(-np.pi, np.pi)
        q = ik.solve(p, yaw, ik.seed_towards(p, yaw, HOME))
        pos, R = ik.fk(q)
        assert np.linalg.norm(pos - p) < 2e-4
        assert np.abs(R - down_rotation(yaw)).max() < 2e-3
        assert ik.collides(q) is None
    for name, centre in layout.BINS.items():
        p = centre + [0, 0, 0.16]
        q = ik.solve(p, 0.0, ik.seed_towards(p, 0.0, HOME), what=f"bin {name}")
        assert np.linalg.norm(ik.fk(q)[0] - p) < 2e-4


def test_seed_turns_the_wrist_the_least(ik):
    _, R = ik.fk(HOME)
    p = np.array([0.3, 0.15, 0.2])
    q = ik.seed_towards(p, tool_yaw(R) + 0.2, HOME)
    assert q[5] == pytest.approx(HOME[5] - 0.2, abs=0.1)


def test_unreachable_target_is_an_ik_error_naming_it(ik):
    with pytest.raises(IKError, match=r"grasp of test part at \[1.5, 0.0, 0.1\] m: out of"):
        ik.solve(np.array([1.5, 0.0, 0.1]), 0.0, HOME, what="grasp of test part")
    # inside the belt: the collision limit holds the tool above it, so no convergence
    p = layout.PICK_ZONE - [0, 0, 0.05]
    with pytest.raises(IKError, match="no convergence"):
        ik.solve(p, 0.0, ik.seed_towards(p, 0.0, HOME))


@pytest.mark.parametrize(("target", "obstacle"), [
    ((0.35, -0.25, -0.01), "table"),  # 10 mm into the table (its top at z = 0)
    ((0.02, 0.48, 0.06), "belt"),  # 20 mm into the belt (its top at z = 0.08)
])
def test_a_target_that_sinks_the_cup_into_the_furniture_is_no_solution(ik, target, obstacle):
    """The QP keeps the links clear, not the cup (it grasps on the belt): such targets came
    back solved, ``collides`` saying 'arm/cup vs table' of the answer."""
    p = np.array(target)
    with pytest.raises(IKError, match=f"the cup would be [0-9.]+ mm inside the {obstacle}"):
        ik.solve(p, 0.3, ik.seed_towards(p, 0.3, HOME), what="test target")
    resting = p + [0.0, 0.0, 0.03 if obstacle == "table" else 0.02]  # the cup on the surface
    assert ik.collides(ik.solve(resting, 0.3, ik.seed_towards(resting, 0.3, HOME)), clearance=-0.001) is None


@pytest.mark.parametrize(("part_yaw", "symmetry", "tool", "natural", "expected"), [
    (0.3, 0, 8, 2.0, 2.0),  # washer: any yaw, so the wrist stays
    (0.3, 6, 1, 2.0, 0.3 + 2 * np.pi / 6 * 2),  # hex nut, one-lip cup: nearest of six
    (0.1, 2, 1, 3.0, 0.1 + np.pi),  # bolt, one-lip cup: either end
    (0.1, 1, 1, 3.0, 0.1),  # L bracket, one-lip cup: one way only
    (0.1, 1, 8, 3.0, 0.1 + 4 * np.pi / 4),  # L bracket, 8-lip cup: nearest 45 deg step
    (0.0, 6, 8, 0.2, np.pi / 12),  # hex nut, 8-lip cup: 15 deg steps
])
def test_tool_yaw_is_the_nearest_symmetric_equivalent(part_yaw, symmetry, tool, natural,
                                                      expected):
    got = choose_tool_yaw(part_yaw, symmetry, natural, tool_symmetry=tool)
    assert got == pytest.approx(expected)


@pytest.mark.parametrize(("position", "yaw", "seed", "culprit"), [
    ([np.nan, 0.0, 0.3], 0.0, HOME, "position"),
    ([0.0, 0.45, 0.3], np.nan, HOME, "yaw"),
    ([0.0, 0.45, 0.3], np.inf, HOME, "yaw"),
    ([0.0, 0.45, 0.3], 0.0, np.full(6, np.nan), "seed"),
    ([0.0, 0.45], 0.0, HOME, "position"),
    ([0.0, 0.45, 0.3], 0.0, HOME[:5], "seed"),
    ([0.0, 0.45, 0.3], 0.0, HOME + [0, 0, 0, 0, 0, 4 * np.pi], "seed"),  # (outside its range:
    ([0.0, 0.45, 0.3], 0.0, HOME + [0, 0, 3.5, 0, 0, 0], "seed"),  # "the QP has no solution")
])
def test_a_target_that_is_not_numbers_is_a_robot_error_naming_it(ik, position, yaw, seed, culprit):
    # (a NaN target once came back as the seed, "solved"; a NaN seed as all-NaN joints).
    # A caller's bug, not an unreachable part: no IKError, which the sort job files as one
    from cell.errors import RobotError

    with pytest.raises(RobotError, match=f"argument '{culprit}'") as info:
        ik.solve(np.array(position), yaw, np.asarray(seed))
    assert not isinstance(info.value, IKError)


def test_a_target_below_the_table_says_so(ik):
    with pytest.raises(IKError, match="below the table"):
        ik.solve(np.array([0.0, 0.4, -0.5]), 0.0, HOME)


@pytest.mark.parametrize(("args", "culprit"), [
    ((np.nan, 4, 0.0), "part_yaw"), ((0.0, 4, np.inf), "natural_yaw"),
    ((0.0, -2, 0.0), "symmetry"), ((0.0, 2.5, 0.0), "symmetry"),
])
def test_choose_tool_yaw_refuses_what_is_no_yaw_or_order(args, culprit):
    from cell.errors import MotionError, RobotError

    with pytest.raises(RobotError, match=f"argument '{culprit}'") as info:
        choose_tool_yaw(*args)
    assert not isinstance(info.value, MotionError)


def test_fk_and_the_collision_check_refuse_joints_that_are_not_six_numbers(ik):
    # (collides(NaN) answered None, read as "no collision"; fk(NaN) gave a NaN pose)
    from cell.errors import RobotError

    for bad in (np.full(6, np.nan), np.zeros(5)):
        with pytest.raises(RobotError, match="argument 'q'"):
            ik.fk(bad)
        with pytest.raises(RobotError, match="argument 'q'"):
            ik.collides(bad)


def test_the_seed_and_clearance_helpers_refuse_what_is_no_number(ik):
    """seed_towards returned NaN seeds for a NaN target, an IndexError for a short one;
    collides(clearance=nan) answered None, read as clear."""
    from cell.errors import RobotError

    p = layout.PICK_ZONE + [0.0, 0.0, 0.05]
    for position, yaw, culprit in (([np.nan, 0.45, 0.1], 0.0, "position"),
                                   ([0.1], 0.0, "position"), (p, np.nan, "yaw")):
        with pytest.raises(RobotError, match=f"argument '{culprit}'"):
            ik.seed_towards(np.array(position), yaw, HOME)
    with pytest.raises(RobotError, match="argument 'clearance'"):
        ik.collides(HOME, clearance=np.nan)
