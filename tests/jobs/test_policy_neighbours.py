"""The sort job's decisions about touching and near parts (``cell.jobs.policy``).

The cup's lip seals over a neighbour within its reach and lifts it along; a part lifted
drags one that touches it. Picks that may carry a part of another bin go to ``reject``;
a part whose pick would disturb a neighbour that can go first without disturbing it
waits. Unit tests on hand-made detections, then one short closed-loop run.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from cell.catalogue import KINDS
from cell.jobs.policy import MixedPick, choose_bin, pick_candidates
from cell.jobs.settings import SortSettings
from cell.sim import layout
from cell.vision.detector import Detection

SETTINGS = SortSettings()
Y = layout.CONVEYOR_Y


def det(id_: int, kind: str, material: str, x: float, y: float = Y, *, yaw: float = 0.0,
        size: tuple[float, float] | None = None) -> Detection:
    """A sure detection of ``kind`` at (x, y) m (nominal size unless given)."""
    if size is None:
        size = (KINDS[kind].length, KINDS[kind].width) if kind in KINDS else (0.02, 0.02)
    return Detection(id=id_, material=material, material_confidence=0.95, kind=kind,
                     kind_confidence=0.95 if kind in KINDS else 0.0, centroid=(320.0, 240.0),
                     yaw=yaw, symmetry=KINDS[kind].symmetry if kind in KINDS else 0,
                     position=(x, y), size=size, partial=False)


def test_a_touching_pair_of_two_bins_goes_to_reject_not_to_one_bin():
    # the audit's case (seed 2): a plastic hex nut with an aluminium square nut against it
    # upstream, as detected; the cup on the hex nut seals over the square nut too
    hex_nut = det(4, "hex_nut", "plastic", 0.0062, 0.4524, yaw=1.05, size=(0.0184, 0.0155))
    square = det(3, "square_nut", "metal", -0.0101, 0.4524, yaw=1.57, size=(0.0143, 0.0131))
    todo = pick_candidates([square, hex_nut], SETTINGS)
    assert [d.id for d in todo] == [4, 3]  # the taller one first: the cup can reach only it
    first = todo[0]
    assert isinstance(first, MixedPick) and first.mixed_with == (3,)
    assert choose_bin(first, SETTINGS) == "reject"
    # it is still the detection it was (the record shows what was seen, and why)
    assert (first.kind, first.material, first.position) == ("hex_nut", "plastic", (0.0062, 0.4524))
    assert first.to_dict()["mixed_with"] == (3,)
    # once the hex nut is gone the square nut is free and goes to its own bin
    assert [choose_bin(d, SETTINGS) for d in pick_candidates([square], SETTINGS)] == ["metal"]


def test_two_touching_nuts_of_two_bins_go_to_reject_whichever_is_first():
    # seed 7: a metal hex nut corner to corner with a plastic one
    a = det(3, "hex_nut", "metal", -0.0134, 0.4683)
    b = det(4, "hex_nut", "plastic", 0.0062, 0.4682)
    todo = pick_candidates([a, b], SETTINGS)
    assert [d.id for d in todo] == [4, 3]
    assert [choose_bin(d, SETTINGS) for d in todo] == ["reject", "reject"]


def test_a_touching_pair_of_one_bin_is_picked_as_usual():
    a = det(1, "hex_nut", "plastic", -0.0134)
    b = det(2, "hex_nut", "plastic", 0.0062)
    todo = pick_candidates([a, b], SETTINGS)
    assert todo == [b, a] and not any(isinstance(d, MixedPick) for d in todo)
    assert [choose_bin(d, SETTINGS) for d in todo] == ["plastic", "plastic"]


def test_a_neighbour_of_unsure_material_sends_the_pick_to_reject():
    nut = det(1, "square_nut", "metal", 0.01)
    blob = det(2, "unknown", "metal", 0.01 - 0.0065 - 0.011)  # a 20 mm blob against it
    todo = pick_candidates([nut, blob], SETTINGS)
    assert {d.id: choose_bin(d, SETTINGS) for d in todo} == {1: "reject", 2: "reject"}


def test_the_free_part_is_picked_before_the_one_whose_cup_would_reach_it():
    # a square nut (downstream, picked first until now) with a disc 4 mm upstream of it:
    # the cup on the nut reaches over the disc's rim, the cup on the disc does not reach
    # the nut, and they do not touch: the disc goes first, each to its own bin
    nut = det(1, "square_nut", "metal", 0.01)
    disc = det(2, "disc", "plastic", 0.01 - 0.0065 - 0.004 - 0.015)
    todo = pick_candidates([nut, disc], SETTINGS)
    assert [d.id for d in todo] == [2, 1]
    assert choose_bin(todo[0], SETTINGS) == "plastic"
    assert [choose_bin(d, SETTINGS) for d in pick_candidates([nut], SETTINGS)] == ["metal"]


def test_the_brackets_footprint_lies_towards_its_long_leg():
    # the L bracket's centroid sits 4.3 mm from its box's centre towards the outer corner
    # (-x, -y at yaw 0): a nut 0.5 mm past the long leg's tip (+x) touches it, one as far
    # out on the other side does not (its footprint ends 15.7 mm from the centroid there)
    bracket = det(1, "l_bracket", "metal", 0.0)
    tip = det(2, "square_nut", "plastic", 0.02434 + 0.0065 + 0.0005)
    back = det(2, "square_nut", "plastic", -(0.02434 + 0.0065 + 0.0005))
    by_id = {d.id: d for d in pick_candidates([bracket, tip], SETTINGS)}
    assert choose_bin(by_id[1], SETTINGS) == "reject"
    by_id = {d.id: d for d in pick_candidates([bracket, back], SETTINGS)}
    assert choose_bin(by_id[1], SETTINGS) == "metal"
    # turned half a turn, the long leg points to -x: now the nut at -x touches it
    turned = det(1, "l_bracket", "metal", 0.0, yaw=3.14159)
    by_id = {d.id: d for d in pick_candidates([turned, back], SETTINGS)}
    assert choose_bin(by_id[1], SETTINGS) == "reject"


def test_parts_apart_keep_their_order_bins_and_objects():
    # the default feed (10 cm apart): nothing changes, the very detections come back
    dets = [det(1, "hex_nut", "metal", -0.09, Y + 0.03), det(2, "l_bracket", "plastic", 0.01, Y - 0.04),
            det(3, "disc", "metal", -0.04, Y + 0.01), det(4, "washer", "plastic", 0.11)]
    todo = pick_candidates(dets, SETTINGS)
    assert [d.id for d in todo] == [4, 2, 3, 1]
    assert all(any(d is o for o in dets) for d in todo)
    assert [choose_bin(d, SETTINGS) for d in todo] == ["plastic", "plastic", "metal", "metal"]


def test_a_neighbour_outside_the_pick_window_still_counts():
    hi = SETTINGS.pick_window[1]
    inside = det(1, "hex_nut", "plastic", hi - 0.001)
    outside = det(2, "hex_nut", "metal", hi - 0.001 + 0.0196)
    todo = pick_candidates([inside, outside], SETTINGS)
    assert [d.id for d in todo] == [1]
    assert choose_bin(todo[0], SETTINGS) == "reject"


def test_a_partial_neighbour_with_a_position_counts_as_any_part_round_it():
    # the detector gives a part at the image border no position (then it cannot be judged);
    # one given a position (its visible piece) may be any part reaching 50 mm from it
    import dataclasses

    washer = det(1, "washer", "plastic", -0.10)
    piece = dataclasses.replace(det(2, "unknown", "metal", -0.10 - 0.055, size=(0.01, 0.012)),
                                partial=True)
    todo = pick_candidates([washer, piece], SETTINGS)
    assert [d.id for d in todo] == [1] and choose_bin(todo[0], SETTINGS) == "reject"
    far = dataclasses.replace(piece, position=(-0.10 - 0.07, Y))
    assert choose_bin(pick_candidates([washer, far], SETTINGS)[0], SETTINGS) == "plastic"


# --- closed loop ---------------------------------------------------------------------

SCENARIOS = Path(__file__).parents[2] / "scenarios"


@pytest.fixture(scope="module")
def calibration():
    from cell.calib.job import run_calibration
    from cell.scenario import load_scenario

    return run_calibration(load_scenario(SCENARIOS / "sort.toml"), camera="overhead",
                           touch=False).calibration


def test_touching_parts_of_two_bins_are_never_binned_wrong(calibration):
    # seed 2: part 2 (aluminium square nut) arrives against part 1 (plastic hex nut); the
    # hex nut's pick used to lift both into the plastic bin
    from cell.jobs.sort import run_sort
    from cell.scenario import load_scenario

    scenario = load_scenario(SCENARIOS / "sort.toml", overrides=[
        "seed=2", "parts.count=4", "faults.touching=[2,4]"])
    report = run_sort(scenario, calibration=calibration).report
    a = report["accounting"]
    assert a["spawned"] == a["binned"] + a["rejected"] + a["missed"] + a["dropped"] == 4
    assert a["binned_wrong"] == 0
    assert report["parts"][1]["outcome"] in ("rejected", "binned_correct")
    first = report["picks"][0]
    assert first["bin"] == "reject" and first["detection"]["mixed_with"]
    assert first["detection"]["material"] == "plastic"  # seen right, sent to reject
