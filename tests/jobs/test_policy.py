"""The sort job's decisions on hand-made detections, as a detector of the user's own may
report them (the built-in detector never reports some of these)."""

from __future__ import annotations

import dataclasses

import pytest

from cell.catalogue import KINDS
from cell.jobs.policy import Attempts, choose_bin, grasp_kind, pick_candidates
from cell.jobs.settings import SortSettings
from cell.sim import layout
from tests.jobs.test_policy_neighbours import det

SETTINGS = SortSettings()
X = float(layout.PICK_ZONE[0])


def test_only_a_sure_whole_part_of_a_known_kind_goes_to_a_bin():
    sure = det(1, "hex_nut", "metal", X)
    assert choose_bin(sure, SETTINGS) == "metal"
    assert choose_bin(dataclasses.replace(sure, partial=True), SETTINGS) == "reject"
    unknown = dataclasses.replace(sure, kind="unknown", kind_confidence=0.9)  # sure of no kind
    assert choose_bin(unknown, SETTINGS) == "reject"
    unsure = dataclasses.replace(sure, kind_confidence=SETTINGS.min_kind_confidence - 0.01)
    assert choose_bin(unsure, SETTINGS) == "reject"


@pytest.mark.parametrize("kind", list(KINDS))
def test_an_unknown_part_is_grasped_as_the_kind_of_its_size(kind):
    k = KINDS[kind]
    unknown = det(1, "unknown", "metal", X, size=(k.length, k.width))
    assert grasp_kind(unknown) == kind
    assert grasp_kind(det(2, kind, "metal", X)) == kind


def test_a_part_off_the_belt_or_partial_is_no_candidate():
    on = det(1, "washer", "plastic", X)
    off = det(2, "washer", "plastic", X, y=layout.CONVEYOR_Y + layout.BELT_WIDTH)
    partial = dataclasses.replace(det(3, "washer", "plastic", X - 0.03), partial=True)
    assert [d.id for d in pick_candidates([on, off, partial], SETTINGS)] == [1]


def test_a_failed_spot_follows_the_belt():
    """A part that failed once at x = 0.10 m rode 50 mm on with the belt: the same part,
    given up (limit 1); a part that stayed put is the same part too; another spot is not."""
    attempts = Attempts(limit=1)
    attempts.failed((0.10, 0.40), encoder=0.0)
    assert attempts.given_up((0.15, 0.40), encoder=0.05)  # carried along
    assert attempts.given_up((0.10, 0.40), encoder=0.05)  # held where it was
    assert not attempts.given_up((0.15, 0.40), encoder=0.0)  # a new part there
