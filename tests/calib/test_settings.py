"""The scenario's [calibration] section and the view plan it drives."""

from __future__ import annotations

import numpy as np
import pytest

from cell.calib.planning import plan_views
from cell.calib.transforms import invert, rotation_angle
from cell.errors import ScenarioError
from cell.scenario import scenario_from_dict


def test_defaults_and_overrides():
    s = scenario_from_dict({}, overrides=["calibration.poses=8", "calibration.joint_noise_deg=0.01"])
    c = s.calibration
    assert (c.poses, c.joint_noise_deg, c.board_inner_corners, c.board_square) == (8, 0.01, (8, 5), 0.025)
    assert scenario_from_dict({}).calibration.poses == 20


@pytest.mark.parametrize(("data", "pattern"), [
    ({"board_inner_corners": [8, 6]}, r"'calibration.board_inner_corners' must be one even and one odd"),
    ({"board_inner_corners": [2, 3]}, r"'calibration.board_inner_corners' = 2 is out of range"),
    ({"flange_board_inner_corners": [4, 2]},
     r"'calibration.flange_board_inner_corners' = 2 is out of range"),
    ({"distance": [0.5, 0.3]}, r"'calibration.distance' must be \[near, far\]"),
    ({"poses": 2}, r"'calibration.poses' = 2 is out of range"),
    ({"joint_noise_deg": -0.1}, r"'calibration.joint_noise_deg' = -0.1 is out of range"),
    ({"detector": "harris"}, r"'calibration.detector' has invalid value 'harris'"),
    ({"distortion_terms": 3}, r"'calibration.distortion_terms' has invalid value 3"),
    ({"board": 1}, r"unknown key 'calibration.board'"),
    ({"flange_board_inner_corners": [7, 5]},
     r"'calibration.flange_board_inner_corners' must be one even and one odd"),
    ({"overhead_tilt": [40, 8]}, r"'calibration.overhead_tilt' must be \[least, most\]"),
    ({"overhead_distortion_terms": 3}, r"'calibration.overhead_distortion_terms' has invalid value 3"),
    ({"refine_intrinsics": 1}, r"'calibration.refine_intrinsics' must be bool"),
])
def test_bad_values_name_the_key(data, pattern):
    with pytest.raises(ScenarioError, match=f"^x.toml: .*{pattern}"):
        scenario_from_dict({"calibration": data}, where="x.toml")


def test_the_plan_is_seeded_and_diverse():
    c = scenario_from_dict({}).calibration
    a = plan_views(c, np.random.default_rng(3), count=20)
    b = plan_views(c, np.random.default_rng(3), count=20)
    assert all(np.array_equal(p.T_base_camera, q.T_base_camera) for p, q in zip(a, b, strict=True))
    tilts = np.array([p.tilt_deg for p in a])
    assert tilts.max() <= c.max_tilt + 1e-9 and tilts.max() > 0.8 * c.max_tilt
    azimuths = np.sort([p.azimuth_deg for p in a])
    assert np.diff(np.append(azimuths, azimuths[0] + 360)).max() < 60  # all around the board
    # pairwise flange motions turn by tens of degrees about axes in every direction
    R = [p.T_base_flange[:3, :3] for p in a]
    angles = [np.degrees(rotation_angle(R[i].T @ R[j])) for i in range(20) for j in range(i)]
    assert np.median(angles) > 30
    for p in a:  # every view looks at the board's centre region from its distance range
        cam = invert(p.T_base_camera)
        centre = cam[:3, :3] @ np.asarray(c.board_position) + cam[:3, 3]
        assert c.distance[0] - 1e-9 <= np.linalg.norm(centre) <= c.distance[1] + 0.03
        assert np.hypot(centre[0], centre[1]) < 0.025


def test_the_views_roll_both_ways_within_max_roll():
    c = scenario_from_dict({"calibration": {"max_roll": 20.0}}).calibration
    rolls = np.array([p.roll_deg for p in plan_views(c, np.random.default_rng(3), count=30)])
    assert np.abs(rolls).max() <= 20.0 + 1e-9 and np.abs(rolls).max() > 15.0
    assert rolls.min() < -10.0 and rolls.max() > 10.0
