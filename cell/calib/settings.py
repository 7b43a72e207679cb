"""``CalibrationSettings``: the ``[calibration]`` section of a scenario.

What a user knows before calibrating: their checkerboards (the one on the table for the
wrist camera, the plate on the tool for the overhead camera: inner corners, square size),
roughly where the table's lies and roughly where the camera sits on the flange (both only
to aim the views; the calibration itself never uses them), how many views to take, and
how noisy the robot's joint readings are (to see how encoder error propagates).
"""

from __future__ import annotations

from dataclasses import dataclass

from cell.config import check, setting
from cell.errors import ScenarioError

__all__ = ["CalibrationSettings"]


@dataclass(frozen=True)
class CalibrationSettings:
    """Capture plan and board of a camera calibration (units in each field's doc)."""

    poses: int = setting(20, lo=3, hi=200, doc="robot poses (views) captured per camera")
    board_inner_corners: tuple[int, ...] = setting(
        (8, 5), lo=3, hi=50, length=2,
        doc="inner corners of the checkerboard along its x and y (one even, one odd)",
    )
    board_square: float = setting(0.025, lo=0.001, hi=1.0, doc="edge of one board square (m)")
    board_position: tuple[float, ...] = setting(
        (0.50, 0.05, 0.0), lo=-2.0, hi=2.0, length=3,
        doc="where the board lies, roughly, in the robot's base frame (m): the views aim here",
    )
    camera_offset: tuple[float, ...] = setting(
        (0.0, 0.06, 0.0), lo=-0.5, hi=0.5, length=3,
        doc="a rough guess (a few cm) of the wrist camera's position in the flange frame, "
        "looking along the flange's z (m): used only to aim the views",
    )
    distance: tuple[float, ...] = setting(
        (0.30, 0.42), lo=0.05, hi=2.0, length=2,
        doc="range of camera-to-board distances of the views (m)",
    )
    max_tilt: float = setting(
        35.0, lo=0.0, hi=70.0, doc="largest tilt of a view's axis from the board's normal (deg)"
    )
    max_roll: float = setting(
        90.0, lo=0.0, hi=180.0, doc="largest turn of a view about its own axis (deg)"
    )
    flange_board_inner_corners: tuple[int, ...] = setting(
        (8, 5), lo=3, hi=50, length=2,
        doc="inner corners of the checkerboard plate on the tool (the overhead camera's target) "
        "along its x and y (one even, one odd)",
    )
    flange_board_square: float = setting(
        0.015, lo=0.001, hi=1.0, doc="edge of one square of the plate on the tool (m)"
    )
    overhead_tilt: tuple[float, ...] = setting(
        (8.0, 40.0), lo=0.0, hi=60.0, length=2,
        doc="range of the tool plate's tilt from lying face up in the overhead camera's views, "
        "about a horizontal axis drawn at random (deg)",
    )
    refine_intrinsics: bool = setting(
        True,
        doc="the overhead camera's refinement frees its intrinsics (fx, fy, cx, cy and the "
        "distortion terms) with its pose and the plate's mount; false: intrinsics fixed",
    )
    joint_noise_deg: float = setting(
        0.0, lo=0.0, hi=1.0,
        doc="standard deviation of the Gaussian noise on each joint reading (deg)",
    )
    detector: str = setting(
        "sb", choices=("sb", "classic"),
        doc="corner detector tried first (the other is the fallback): sb = "
        "findChessboardCornersSB, classic = findChessboardCorners + cornerSubPix",
    )
    multisample: int = setting(
        4, choices=(0, 4),
        doc="samples per pixel of the calibration renders (0: the simulator's aliased default); "
        "a real sensor integrates light over each pixel's area",
    )
    distortion_terms: int = setting(
        4, choices=(0, 2, 4, 5),
        doc="distortion coefficients estimated for the wrist camera: 0 none, 2 (k1, k2), "
        "4 (k1, k2, p1, p2), 5 (+ k3)",
    )
    overhead_distortion_terms: int = setting(
        2, choices=(0, 2, 4, 5),
        doc="distortion coefficients estimated for the overhead camera, as distortion_terms; "
        "2 by default: on its views of the small tool plate the tangential terms trade against "
        "the principal point (README, Calibration)",
    )

    def __post_init__(self) -> None:
        check(self, "calibration")  # every field, however the object was made

    def _validate(self, where: str) -> None:
        nx, ny = self.board_inner_corners
        if (nx + ny) % 2 == 0:
            raise ScenarioError(
                f"{where}: key 'calibration.board_inner_corners' must be one even and one odd "
                f"count (a board that looks the same turned by 180 degrees has no unique "
                f"origin), got {nx} x {ny}")
        nx, ny = self.flange_board_inner_corners
        if (nx + ny) % 2 == 0:
            raise ScenarioError(
                f"{where}: key 'calibration.flange_board_inner_corners' must be one even and one "
                f"odd count (a board that looks the same turned by 180 degrees has no unique "
                f"origin), got {nx} x {ny}")
        lo, hi = self.overhead_tilt
        if lo > hi:
            raise ScenarioError(
                f"{where}: key 'calibration.overhead_tilt' must be [least, most] with least <= "
                f"most, got [{lo}, {hi}]")
        lo, hi = self.distance
        if lo > hi:
            raise ScenarioError(
                f"{where}: key 'calibration.distance' must be [near, far] with near <= far, "
                f"got [{lo}, {hi}]")
