"""Shared fixtures: small scenarios and worlds built without the arm (faster)."""

from __future__ import annotations

import pytest

from cell.scenario import scenario_from_dict
from cell.sim.world import World


def make_world(arm: bool = False, **sections) -> World:
    """A world from a scenario dict (``seed=3, parts={"count": 2}`` ...)."""
    return World.build(scenario_from_dict(sections), arm=arm)


def _factory():
    worlds = []

    def factory(arm: bool = False, **sections) -> World:
        w = make_world(arm=arm, **sections)
        worlds.append(w)
        return w

    return factory, worlds


@pytest.fixture
def world_factory():
    """Builds worlds (``factory(arm=False, **scenario_sections)``), closed after the test."""
    factory, worlds = _factory()
    yield factory
    for w in worlds:
        w.close()


@pytest.fixture(scope="module")
def module_world_factory():
    """As ``world_factory``, shared by the tests of one module."""
    factory, worlds = _factory()
    yield factory
    for w in worlds:
        w.close()
