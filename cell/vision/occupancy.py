"""Occupancy grid of the table from an image, and breadth-first path search on it.

Foreign objects are segmented by a threshold, cleaned by connected-component
labeling (specks below ``min_area`` dropped), and the image is cut into square cells:
a cell is occupied when enough of its pixels belong to an object. A breadth-first
search then finds a shortest path of free cells. Under 4-connectivity a path moves
only through cell edges; under 8-connectivity also diagonally, even between two
occupied cells that touch at a corner: the syllabus' diagonal-gap case, passable
under 8 and blocked under 4.

References: A. Elfes, "Using occupancy grids for mobile robot perception and
navigation", Computer 22(6), 1989; Cormen et al., *Introduction to Algorithms*,
22.2 (breadth-first search); Gonzalez & Woods 2.5 (4- and 8-adjacency).
"""

from __future__ import annotations

import numbers
from collections import deque
from dataclasses import dataclass

import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_array, check_choice, check_gray, check_int, check_range
from cell.vision.labeling import Components, label_components
from cell.vision.threshold import threshold_fixed, threshold_otsu

__all__ = ["OccupancyGrid", "bfs_path", "occupancy_grid"]


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """``grid`` bool (rows, cols), True = occupied; ``cell_px`` the cell edge in image
    pixels (cell (r, c) covers rows r*cell_px .. and columns c*cell_px ..);
    ``threshold`` the grey level used; ``objects`` the labeled objects."""

    grid: np.ndarray
    cell_px: int
    threshold: float
    objects: Components


def occupancy_grid(
    image: np.ndarray,
    *,
    cell_px: int,
    threshold: float | None = None,
    polarity: str = "bright",
    min_area: int = 20,
    fill: float = 0.0,
) -> OccupancyGrid:
    """Threshold, label and grid an image of the table.

    Parameters
    ----------
    image : uint8 (H, W) grey image of the table.
    cell_px : cell edge in pixels, 1 to 2**31 - 1; a partial last row/column counts
        as a cell (a cell larger than the image is one cell).
    threshold : grey level 0..255; None uses Otsu's (:func:`threshold_otsu`; an image
        of one grey level, an empty and evenly lit table, then has no objects).
    polarity : "bright" (objects brighter than the table) or "dark".
    min_area : objects smaller than this (pixels, 0 to 2**31 - 1) are noise and
        ignored.
    fill : a cell is occupied when more than this fraction, in [0, 1), of its
        pixels belong to objects (0: any object pixel).
    """
    image = check_gray("image", image)
    cell_px = check_int("cell_px", cell_px, 1, 2**31 - 1)
    if threshold is not None:
        threshold = check_range("threshold", threshold, 0, 255)
    if check_range("fill", fill, 0.0, 1.0) == 1.0:
        raise VisionError("argument 'fill': expected a number in [0, 1), got 1.0")
    min_area = check_int("min_area", min_area, 0, 2**31 - 1)
    t = float(threshold_otsu(image) if threshold is None else threshold)
    mask = threshold_fixed(image, value=t, polarity=polarity)
    if threshold is None and image.min() == image.max():
        mask[:] = False  # one grey level: no two classes for Otsu's to tell apart
    if min_area > mask.size:  # no object can be that large (label_components takes <= H*W)
        mask, min_area = np.zeros_like(mask), 0
    objects = label_components(mask, connectivity=8, min_area=min_area)
    occ = (objects.labels > 0).astype(np.int64)
    h, w = occ.shape
    top, left = np.arange(0, h, cell_px), np.arange(0, w, cell_px)  # each cell's first pixel
    count = np.add.reduceat(np.add.reduceat(occ, top, axis=0), left, axis=1)
    area = np.outer(np.diff(top, append=h), np.diff(left, append=w))
    return OccupancyGrid(count / area > fill, cell_px, t, objects)


_STEPS = {
    4: ((-1, 0), (1, 0), (0, -1), (0, 1)),
    8: ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)),
}


def _free_cell(name: str, cell: object, grid: np.ndarray) -> tuple[int, int]:
    """``cell`` as a (row, col) pair of ints, inside ``grid`` and free."""
    try:
        r, c = cell  # type: ignore[misc]
    except (TypeError, ValueError):
        r = c = None
    if not all(isinstance(v, numbers.Integral) and not isinstance(v, bool | np.bool_)
               for v in (r, c)):
        raise VisionError(f"argument '{name}': expected a (row, col) pair of integers, got {cell!r}")
    rows, cols = grid.shape
    if not (0 <= r < rows and 0 <= c < cols):
        raise VisionError(f"argument '{name}': cell {(r, c)} is outside the {rows}x{cols} grid")
    if grid[r, c]:
        raise VisionError(f"argument '{name}': cell {(r, c)} is occupied")
    return int(r), int(c)


def bfs_path(
    grid: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    *,
    connectivity: int = 4,
) -> list[tuple[int, int]] | None:
    """Shortest path (fewest moves) of free cells from ``start`` to ``goal``.

    Parameters
    ----------
    grid : bool (rows, cols), True = occupied.
    start, goal : (row, col) cells, integers inside the grid; both must be free.
    connectivity : 4 (edge moves) or 8 (also diagonal moves, allowed even between
        two occupied cells that share only a corner).

    Returns the list of (row, col) cells from start to goal inclusive, or None when
    the goal cannot be reached. Breadth-first search, O(rows * cols).
    """
    g = check_array("grid", grid, dtypes=(np.bool_,), ndim=(2,))
    check_choice("connectivity", connectivity, (4, 8))
    rows, cols = g.shape
    start, goal = _free_cell("start", start, g), _free_cell("goal", goal, g)
    parent = -np.ones((rows, cols, 2), np.int64)
    seen = g.copy()
    seen[start] = True
    queue = deque([start])
    steps = _STEPS[connectivity]
    while queue:
        r, c = queue.popleft()
        if (r, c) == goal:
            path = [goal]
            while path[-1] != start:
                pr, pc = parent[path[-1]]
                path.append((int(pr), int(pc)))
            return path[::-1]
        for dr, dc in steps:
            nr, nc = r + dr, c + dc
            if 0 <= nr < rows and 0 <= nc < cols and not seen[nr, nc]:
                seen[nr, nc] = True
                parent[nr, nc] = (r, c)
                queue.append((nr, nc))
    return None
