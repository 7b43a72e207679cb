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

from collections import deque
from dataclasses import dataclass

import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_array, check_choice, check_gray
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
    cell_px : cell edge in pixels (>= 1); a partial last row/column counts as a cell.
    threshold : grey level; None uses Otsu's.
    polarity : "bright" (objects brighter than the table) or "dark".
    min_area : objects smaller than this (pixels) are noise and ignored.
    fill : a cell is occupied when more than this fraction (0..1) of its pixels
        belong to objects (0: any object pixel).
    """
    image = check_gray("image", image)
    if not isinstance(cell_px, int | np.integer) or cell_px < 1:
        raise VisionError(f"argument 'cell_px': expected an integer >= 1, got {cell_px!r}")
    if not 0.0 <= fill < 1.0:
        raise VisionError(f"argument 'fill': expected in [0, 1), got {fill!r}")
    t = float(threshold_otsu(image) if threshold is None else threshold)
    mask = threshold_fixed(image, value=t, polarity=polarity)
    objects = label_components(mask, connectivity=8, min_area=min_area)
    occ = objects.labels > 0
    h, w = occ.shape
    rows, cols = -(-h // cell_px), -(-w // cell_px)
    padded = np.zeros((rows * cell_px, cols * cell_px), np.float64)
    padded[:h, :w] = occ
    frac = padded.reshape(rows, cell_px, cols, cell_px).sum(axis=(1, 3))
    area = np.full((rows, cols), float(cell_px * cell_px))
    area[-1, :] = (h - (rows - 1) * cell_px) * cell_px
    area[:, -1] = cell_px * (w - (cols - 1) * cell_px)
    area[-1, -1] = (h - (rows - 1) * cell_px) * (w - (cols - 1) * cell_px)
    return OccupancyGrid(frac / area > fill, int(cell_px), t, objects)


_STEPS = {
    4: ((-1, 0), (1, 0), (0, -1), (0, 1)),
    8: ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)),
}


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
    start, goal : (row, col) cells; both must be free.
    connectivity : 4 (edge moves) or 8 (also diagonal moves, allowed even between
        two occupied cells that share only a corner).

    Returns the list of (row, col) cells from start to goal inclusive, or None when
    the goal cannot be reached. Breadth-first search, O(rows * cols).
    """
    g = check_array("grid", grid, dtypes=(np.bool_,), ndim=(2,))
    check_choice("connectivity", connectivity, (4, 8))
    rows, cols = g.shape
    for name, (r, c) in (("start", start), ("goal", goal)):
        if not (0 <= r < rows and 0 <= c < cols):
            raise VisionError(f"argument '{name}': cell {(r, c)} is outside the {rows}x{cols} grid")
        if g[r, c]:
            raise VisionError(f"argument '{name}': cell {(r, c)} is occupied")
    start, goal = (int(start[0]), int(start[1])), (int(goal[0]), int(goal[1]))
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
