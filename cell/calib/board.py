"""The checkerboard: its known geometry and its corners found in an image.

The board frame: origin at the inner corner next to the board's black corner square,
x along the rows of ``nx`` inner corners, y along the columns of ``ny``, z out of the
printed face (so a board lying face up has z up). Corner ``(i, j)`` sits at
``(i * square, j * square, 0)`` and has index ``j * nx + i``. With one count even and
the other odd, the board turned by 180 degrees shows its other colour at that corner,
so this frame is unique in every view (a board of two even or two odd counts is refused
by the settings).

Two detectors, each the other's fallback: OpenCV's classic pipeline (Bradski and Kaehler,
*Learning OpenCV*, 2008, ch. 11: ``cv2.findChessboardCorners`` then ``cv2.cornerSubPix``)
and ``cv2.findChessboardCornersSB`` (Duda and Frese, "Accurate detection and localization
of checkerboard corners for calibration", BMVC 2018; sub-pixel by a localized Radon
transform). On this cell's wrist views (sensor noise, tilted and slightly aliased edges)
SB's corners are about twice as accurate (README, Calibration), so the scenario's
``calibration.detector`` defaults to it. The detected grid is then put in the board
frame's order: mirrored if its handedness shows the back of the board, turned by 180
degrees if the square diagonally outside corner 0 is not the dark one.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.errors import CalibrationError

__all__ = ["DETECTORS", "Board", "BoardView", "detect_board"]

_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)


@dataclass(frozen=True)
class Board:
    """A checkerboard: ``inner_corners`` (nx, ny) and the ``square`` edge (m)."""

    inner_corners: tuple[int, int]
    square: float

    def __post_init__(self) -> None:
        nx, ny = self.inner_corners
        if nx < 2 or ny < 2 or (nx + ny) % 2 == 0:
            raise CalibrationError(f"board: inner corners must be >= 2 each, one even and one odd, "
                                   f"got {nx} x {ny}")
        if not self.square > 0:
            raise CalibrationError(f"board: square must be > 0 (m), got {self.square}")

    @classmethod
    def from_settings(cls, settings: object) -> Board:
        """The board of a scenario's ``[calibration]`` section."""
        nx, ny = settings.board_inner_corners
        return cls((int(nx), int(ny)), float(settings.board_square))

    @classmethod
    def on_tool_from_settings(cls, settings: object) -> Board:
        """The plate on the tool of a scenario's ``[calibration]`` section (the overhead
        camera's target: ``flange_board_inner_corners``, ``flange_board_square``)."""
        nx, ny = settings.flange_board_inner_corners
        return cls((int(nx), int(ny)), float(settings.flange_board_square))

    @property
    def count(self) -> int:
        """Number of inner corners."""
        return self.inner_corners[0] * self.inner_corners[1]

    def object_points(self) -> np.ndarray:
        """Inner corners in the board frame (N, 3), metres, index ``j * nx + i``."""
        nx, ny = self.inner_corners
        gx, gy = np.meshgrid(np.arange(nx, dtype=np.float64), np.arange(ny, dtype=np.float64))
        return np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1) * self.square


@dataclass(frozen=True, eq=False)
class BoardView:
    """The board's inner corners found in one image: ``corners`` (N, 2) pixels in the
    board's index order; ``detector`` is ``"classic"`` or ``"sb"``."""

    corners: np.ndarray
    detector: str


def _grey(image: np.ndarray) -> np.ndarray:
    """The grey image of a uint8 (H, W) or (H, W, 3) RGB one; anything else is refused."""
    ok = (isinstance(image, np.ndarray) and image.dtype == np.uint8 and image.size > 0
          and (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)))
    if not ok:
        got = (f"{image.dtype} {image.shape}" if isinstance(image, np.ndarray)
               else type(image).__name__)
        raise CalibrationError(f"detect_board: expected a uint8 (H, W) or (H, W, 3) image, got {got}")
    if image.ndim == 3:
        return cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2GRAY)
    return np.ascontiguousarray(image)


def _subpix_window(grid: np.ndarray) -> int:
    """Half-size (px) of the corner refinement window: a third of the shortest corner spacing,
    so that a window never reaches the next corner."""
    dx = np.linalg.norm(np.diff(grid, axis=1), axis=2).min()
    dy = np.linalg.norm(np.diff(grid, axis=0), axis=2).min()
    return int(np.clip(min(dx, dy) / 3.0, 2, 11))


def _classic(grey: np.ndarray, pattern: tuple[int, int]) -> np.ndarray | None:
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
    found, corners = cv2.findChessboardCorners(grey, pattern, flags=flags)
    if not found:
        return None
    grid = corners.reshape(pattern[1], pattern[0], 2)
    half = _subpix_window(grid)
    refined = cv2.cornerSubPix(grey, corners, (half, half), (-1, -1), _SUBPIX_CRITERIA)
    return refined.reshape(-1, 2).astype(np.float64)


def _sb(grey: np.ndarray, pattern: tuple[int, int]) -> np.ndarray | None:
    flags = cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
    found, corners = cv2.findChessboardCornersSB(grey, pattern, flags=flags)
    return corners.reshape(-1, 2).astype(np.float64) if found else None


def _mean_at(grey: np.ndarray, point: np.ndarray, radius: int) -> float:
    h, w = grey.shape
    x, y = int(round(point[0])), int(round(point[1]))
    patch = grey[max(0, y - radius): min(h, y + radius + 1), max(0, x - radius): min(w, x + radius + 1)]
    return float(patch.mean()) if patch.size else float("nan")


def _canonical(grey: np.ndarray, corners: np.ndarray, board: Board) -> np.ndarray | None:
    """``corners`` reordered into the board frame's index order (see the module docstring),
    or None when the colour test is inconclusive (square centres out of the image)."""
    nx, ny = board.inner_corners
    grid = corners.reshape(ny, nx, 2)
    u, v = grid[0, 1] - grid[0, 0], grid[1, 0] - grid[0, 0]
    if u[0] * v[1] - u[1] * v[0] > 0:  # x cross y points away from the camera: mirrored
        grid = grid[:, ::-1]
    ij = board.object_points()[:, :2] / board.square
    H, _ = cv2.findHomography(ij, grid.reshape(-1, 2), 0)
    if H is None:
        return None
    probes = np.array([[[-0.5, -0.5]], [[0.5, -0.5]]])  # diagonal square, its neighbour along x
    diag, side = cv2.perspectiveTransform(probes, H).reshape(2, 2)
    radius = max(1, _subpix_window(grid) // 2)
    dark, light = _mean_at(grey, diag, radius), _mean_at(grey, side, radius)
    if not (np.isfinite(dark) and np.isfinite(light)) or abs(dark - light) < 10:
        return None
    if dark > light:
        grid = grid[::-1, ::-1]
    return grid.reshape(-1, 2).copy()


DETECTORS = {"classic": _classic, "sb": _sb}


def detect_board(image: np.ndarray, board: Board, *, first: str = "classic") -> BoardView | None:
    """The board's inner corners in ``image`` (uint8 RGB or grey), or None when not found.

    The ``first`` detector (``"classic"``: ``findChessboardCorners`` + ``cornerSubPix``;
    ``"sb"``: ``findChessboardCornersSB``) is tried first, the other when it fails; a view
    whose corner order cannot be made unique is not found either.
    """
    if first not in DETECTORS:
        raise CalibrationError(f"detect_board: unknown detector {first!r}; valid: {', '.join(DETECTORS)}")
    grey = _grey(image)
    pattern = board.inner_corners
    order = [first] + [name for name in DETECTORS if name != first]
    for name in order:
        find = DETECTORS[name]
        corners = find(grey, pattern)
        if corners is None:
            continue
        ordered = _canonical(grey, corners, board)
        if ordered is not None:
            return BoardView(ordered, name)
    return None
