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
