"""The checkerboard: geometry from its settings, corners found in the board's own order."""

from __future__ import annotations

import numpy as np
import pytest

from cell.calib.board import Board, detect_board
from cell.calib.settings import CalibrationSettings
from cell.calib.transforms import make_transform, transform_from_rvec
from cell.errors import CalibrationError
from tests.calib.synthetic import BOARD, K_TRUE, board_image

_FACING = np.diag([1.0, -1.0, -1.0])  # the board's face (+z) towards the camera


def _view(rvec, distance: float = 0.35) -> tuple[np.ndarray, np.ndarray]:
    """(image, true corner pixels) of the board turned by ``rvec``, its centre ``distance``
    (m) ahead of the camera."""
    R = transform_from_rvec(rvec, np.zeros(3))[:3, :3] @ _FACING
    centre = BOARD.object_points().mean(axis=0)
    T = make_transform(R, [0.0, 0.0, distance] - R @ centre)
    H = K_TRUE @ np.column_stack([T[:3, 0], T[:3, 1], T[:3, 3]])
    P = BOARD.object_points() @ T[:3, :3].T + T[:3, 3]
    truth = P[:, :2] / P[:, 2:] @ K_TRUE[:2, :2].T + K_TRUE[:2, 2]
    return board_image(H), truth


def test_object_points_follow_the_board_geometry():
    b = Board((8, 5), 0.025)
    P = b.object_points()
    assert P.shape == (40, 3) and b.count == 40
    assert P[1] == pytest.approx([0.025, 0.0, 0.0]) and P[8] == pytest.approx([0.0, 0.025, 0.0])
    assert P[-1] == pytest.approx([0.175, 0.1, 0.0])


@pytest.mark.parametrize("corners", [(8, 6), (7, 5), (1, 4)])
def test_a_board_without_a_unique_origin_is_refused(corners):
    with pytest.raises(CalibrationError, match="one even and one odd"):
        Board(corners, 0.025)


@pytest.mark.parametrize("first", ["classic", "sb"])
@pytest.mark.parametrize("rvec", [[0.3, -0.2, 0.4], [-0.2, 0.3, 2.6], [0.1, 0.35, -1.7]])
def test_corners_are_found_in_board_order_to_a_tenth_of_a_pixel(first, rvec):
    image, truth = _view(rvec)
    view = detect_board(image, BOARD, first=first)
    assert view is not None and view.detector == first
    assert np.abs(view.corners - truth).max() < 0.1


def test_the_image_turned_half_way_gives_the_same_physical_corners():
    image, truth = _view([0.2, -0.1, 0.3])
    turned = np.ascontiguousarray(image[::-1, ::-1])
    view = detect_board(turned, BOARD)
    h, w = image.shape
    assert np.abs((np.array([w - 1, h - 1]) - view.corners) - truth).max() < 0.1


def test_no_board_no_corners():
    assert detect_board(np.full((480, 640, 3), 128, np.uint8), BOARD) is None
    with pytest.raises(CalibrationError, match="unknown detector 'x'"):
        detect_board(np.zeros((48, 64), np.uint8), BOARD, first="x")


@pytest.mark.parametrize("image", [np.zeros((48, 64), np.float64), np.zeros((48, 64, 4), np.uint8),
                                   np.zeros((0, 64), np.uint8), "board.png"])
def test_detect_board_refuses_what_is_not_a_uint8_grey_or_rgb_image(image):
    with pytest.raises(CalibrationError, match="detect_board: expected a uint8"):
        detect_board(image, BOARD)


def test_the_plate_on_the_tool_is_read_from_its_own_keys():
    s = CalibrationSettings(flange_board_inner_corners=(6, 5), flange_board_square=0.02)
    assert Board.on_tool_from_settings(s) == Board((6, 5), 0.02)
    assert Board.from_settings(s) == Board((8, 5), 0.025)


def test_a_far_board_keeps_its_corners_to_a_tenth_of_a_pixel():
    # corners ~14 px apart: a refinement window reaching the next corner pulls them ~1 px off
    image, truth = _view([0.3, -0.2, 0.4], distance=0.9)
    view = detect_board(image, BOARD, first="classic")
    assert view is not None and view.detector == "classic"
    assert np.abs(view.corners - truth).max() < 0.1
