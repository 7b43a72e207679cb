"""Eye-to-hand (a fixed camera, a board on the flange) on exact and noisy synthetic projections:
SHAH and LI through OpenCV's robot-world solver, the consistency choice, the refinement with
the intrinsics fixed and freed."""

from __future__ import annotations

import numpy as np
import pytest

from cell.calib.eyetohand import (
    ROBOT_WORLD_METHODS,
    compare_eye_to_hand,
    consistency_fixed,
    reprojection_fixed,
    solve_eye_to_hand,
)
from cell.calib.handeye import HandEyeData, project
from cell.calib.overhead import solve_overhead
from cell.calib.refine import refine_eye_to_hand
from cell.calib.transforms import invert, make_transform, pose_error, transform_from_rvec
from cell.errors import CalibrationError
from tests.calib.synthetic import C_TRUE, G_TRUE, K_FIXED, PLATE, SIZE, fixed_views


@pytest.fixture(scope="module")
def exact():
    return fixed_views(12, seed=21)


def _data(v, K=K_FIXED, dist=None) -> HandEyeData:
    return HandEyeData(PLATE.object_points(), v["corners"], v["T_base_flange"], v["T_camera_board"], K,
                       np.zeros(5) if dist is None else dist)


def test_the_synthetic_views_are_in_the_image(exact):
    c = exact["corners"]
    assert c[..., 0].min() > 0 and c[..., 0].max() < SIZE[0] - 1
    assert c[..., 1].min() > 0 and c[..., 1].max() < SIZE[1] - 1
    assert np.allclose(reprojection_fixed(_data(exact), C_TRUE, G_TRUE), c, atol=1e-9)


@pytest.mark.parametrize("method", list(ROBOT_WORLD_METHODS))
def test_each_method_recovers_the_camera_and_the_mount_from_exact_data(exact, method):
    C, G = solve_eye_to_hand(_data(exact), method=method)
    rot, trans = pose_error(C, C_TRUE)
    assert rot < 1e-6 and trans < 1e-8
    rot, trans = pose_error(G, G_TRUE)
    assert rot < 1e-6 and trans < 1e-8


def test_the_consistency_error_is_zero_at_the_truth_and_grows_off_it(exact):
    data = _data(exact)
    G, rms = consistency_fixed(data, C_TRUE)
    assert rms < 1e-8 and pose_error(G, G_TRUE)[1] < 1e-10
    off = C_TRUE @ transform_from_rvec([0.0, 0.002, 0.0], [0.001, 0.0, 0.0])
    assert consistency_fixed(data, off)[1] > 0.1
    estimates, chosen = compare_eye_to_hand(data)
    assert {e.method for e in estimates} == set(ROBOT_WORLD_METHODS) and chosen in ROBOT_WORLD_METHODS


@pytest.mark.parametrize("free", [False, True])
def test_the_refinement_recovers_from_a_perturbed_start(exact, free):
    data = _data(exact)
    start = C_TRUE @ transform_from_rvec([0.01, -0.01, 0.02], [0.002, -0.003, 0.001])
    ref = refine_eye_to_hand(data, start, free_intrinsics=free, terms=4)
    assert ref.start_rms_px > 1.0 and ref.rms_px < 1e-6 and ref.free_intrinsics is free
    rot, trans = pose_error(ref.T_base_camera, C_TRUE)
    assert rot < 1e-6 and trans < 1e-8
    assert pose_error(ref.T_flange_board, G_TRUE)[1] < 1e-8
    assert pytest.approx(K_FIXED, abs=1e-5) == ref.K


def test_freed_intrinsics_move_to_the_truth_and_fixed_ones_stay(exact):
    K_off = K_FIXED + np.array([[0.8, 0.0, -0.6], [0.0, 0.9, 0.5], [0.0, 0.0, 0.0]])
    dist_off = np.array([0.02, 0.0, 0.0, 0.0, 0.0])
    data = _data(exact, K=K_off, dist=dist_off)
    fixed = refine_eye_to_hand(data, C_TRUE, T_flange_board=G_TRUE, free_intrinsics=False)
    assert np.array_equal(fixed.K, K_off) and np.array_equal(fixed.dist, dist_off) and fixed.rms_px > 0.05
    free = refine_eye_to_hand(data, C_TRUE, T_flange_board=G_TRUE, free_intrinsics=True, terms=2)
    assert free.rms_px < 1e-6 and pytest.approx(K_FIXED, abs=1e-4) == free.K
    assert free.dist == pytest.approx(np.zeros(5), abs=1e-7)
    assert pose_error(free.T_base_camera, C_TRUE)[0] < 1e-6


def test_with_pixel_noise_every_step_stays_close_and_the_refinement_fits_best():
    v = fixed_views(20, seed=22, noise_px=0.05)
    solution = solve_overhead(v["corners"], v["T_base_flange"], PLATE, image_size=SIZE, terms=4,
                              free_intrinsics=True)
    intr, ref, best = solution.intrinsics, solution.refinement, solution.best
    assert abs(intr.K[0, 0] / K_FIXED[0, 0] - 1) < 2e-3
    assert best.method == solution.chosen and len(solution.estimates) >= 2
    assert ref.rms_px <= best.consistency_px and ref.rms_px < 0.08  # 0.05 px per axis: 0.071 px
    for T in (best.T_base_camera, ref.T_base_camera):
        rot, trans = pose_error(T, C_TRUE)
        assert rot < 0.05 and trans < 5e-4


def test_bad_inputs_are_calibration_errors(exact):
    with pytest.raises(CalibrationError, match="eye-to-hand: unknown method 'PARK'; valid: SHAH, LI"):
        solve_eye_to_hand(_data(exact), method="PARK")
    with pytest.raises(CalibrationError, match="terms must be one of"):
        refine_eye_to_hand(_data(exact), C_TRUE, terms=3)


def test_views_that_turn_about_one_axis_only_are_refused_and_name_the_tilt_key():
    # the board only spins about its normal: AX = ZB has no unique answer, and without the
    # check a method answers anyway (LI: 180 deg off the truth)
    obj = PLATE.object_points()
    centre = obj.mean(axis=0)
    flanges, corners, poses = [], [], []
    for i, a in enumerate(np.radians([-50, -25, 0, 20, 45, 60])):
        R = transform_from_rvec([0.0, 0.0, a], np.zeros(3))[:3, :3]
        T_camera_board = make_transform(R, np.array([0.01 * i - 0.02, 0.005 * i, 0.25]) - R @ centre)
        flanges.append(C_TRUE @ T_camera_board @ invert(G_TRUE))
        poses.append(T_camera_board)
        corners.append(project(obj @ R.T + T_camera_board[:3, 3], K_FIXED, np.zeros(5)))
    data = HandEyeData(obj, np.array(corners), np.array(flanges), np.array(poses), K_FIXED, np.zeros(5))
    with pytest.raises(CalibrationError, match=r"eye-to-hand: the views turn about one axis only.*"
                                               r"calibration\.overhead_tilt"):
        compare_eye_to_hand(data)
