"""Shared fixtures: small scenarios and worlds built without the arm (faster)."""

from __future__ import annotations

import cv2
import pytest

from cell.scenario import scenario_from_dict
from cell.sim.world import World


@pytest.fixture(scope="session", autouse=True)
def _no_rerun_switch():
    """No ``RERUN`` from the caller's environment (``RERUN=off`` refuses replays): the
    tests that want it set it themselves."""
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("RERUN", raising=False)
        yield


@pytest.fixture(autouse=True)
def _opencv_threads_put_back():
    """OpenCV's thread count put back after each test (the vision bench and a sweep run
    in-process set it to one), so no test's result depends on which ran before it."""
    threads = cv2.getNumThreads()
    yield
    cv2.setNumThreads(threads)


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
