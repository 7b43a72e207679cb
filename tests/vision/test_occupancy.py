import numpy as np
import pytest

from cell.errors import VisionError
from cell.vision.occupancy import bfs_path, occupancy_grid


def _diagonal_gap_grid():
    """A wall across a 10 x 10 grid whose two halves meet only at a corner."""
    g = np.zeros((10, 10), bool)
    g[5, 0:5] = True
    g[4, 5:10] = True
    return g


def _valid(path, grid, connectivity):
    for (r0, c0), (r1, c1) in zip(path, path[1:], strict=False):
        dr, dc = abs(r1 - r0), abs(c1 - c0)
        assert max(dr, dc) == 1 and (connectivity == 8 or dr + dc == 1)
        assert not grid[r1, c1]
    return True


def test_diagonal_gap_passable_under_8_blocked_under_4():
    grid = _diagonal_gap_grid()
    start, goal = (0, 0), (9, 9)
    assert bfs_path(grid, start, goal, connectivity=4) is None
    path = bfs_path(grid, start, goal, connectivity=8)
    assert path is not None and path[0] == start and path[-1] == goal
    assert _valid(path, grid, 8)
    assert any({a, b} == {(4, 4), (5, 5)} for a, b in zip(path, path[1:], strict=False))


def test_bfs_is_shortest_on_an_open_grid():
    grid = np.zeros((12, 15), bool)
    p4 = bfs_path(grid, (1, 2), (9, 13), connectivity=4)
    p8 = bfs_path(grid, (1, 2), (9, 13), connectivity=8)
    assert len(p4) - 1 == 8 + 11  # Manhattan distance
    assert len(p8) - 1 == max(8, 11)  # Chebyshev distance
    assert _valid(p4, grid, 4) and _valid(p8, grid, 8)
    assert bfs_path(grid, (3, 3), (3, 3)) == [(3, 3)]


def test_occupancy_grid_from_an_image_keeps_the_diagonal_gap():
    """Objects (bright boxes) placed on the table so they touch only at a corner."""
    rng = np.random.default_rng(50)
    img = rng.normal(60, 6, (200, 200))
    cell = 20
    for r, c in np.argwhere(_diagonal_gap_grid()):
        img[r * cell + 2 : (r + 1) * cell - 2, c * cell + 2 : (c + 1) * cell - 2] = 200
    img[100:102, 100:102] = 255  # a speck of glare: below min_area, not an object
    img = np.clip(img, 0, 255).astype(np.uint8)
    occ = occupancy_grid(img, cell_px=cell, min_area=20)
    np.testing.assert_array_equal(occ.grid, _diagonal_gap_grid())
    assert occ.objects.count == 10 and 60 < occ.threshold < 200
    assert bfs_path(occ.grid, (0, 0), (9, 9), connectivity=4) is None
    assert bfs_path(occ.grid, (0, 0), (9, 9), connectivity=8) is not None


@pytest.mark.parametrize("polarity", ["bright", "dark"])
def test_an_evenly_lit_empty_table_is_free(polarity):
    """An image of one grey level holds no objects for Otsu's threshold to find, whatever
    the polarity (every cell was occupied)."""
    grid = occupancy_grid(np.full((120, 160), 90, np.uint8), cell_px=40, polarity=polarity)
    assert not grid.grid.any() and grid.objects.count == 0


def test_partial_cells_and_fill_fraction():
    img = np.zeros((25, 25), np.uint8)
    img[20:25, 20:25] = 255  # fills the partial corner cell completely
    img[0:3, 0:3] = 255  # 9 of 100 pixels of the first cell
    assert occupancy_grid(img, cell_px=10, threshold=128, min_area=1).grid.sum() == 2
    grid = occupancy_grid(img, cell_px=10, threshold=128, min_area=1, fill=0.5).grid
    assert grid.tolist() == [[False, False, False], [False, False, False], [False, False, True]]


def test_occupancy_errors_name_the_argument():
    grid = _diagonal_gap_grid()
    with pytest.raises(VisionError, match="start.*occupied"):
        bfs_path(grid, (5, 0), (0, 0))
    with pytest.raises(VisionError, match="goal.*outside"):
        bfs_path(grid, (0, 0), (10, 0))
    with pytest.raises(VisionError, match="connectivity"):
        bfs_path(grid, (0, 0), (1, 1), connectivity=6)
    with pytest.raises(VisionError, match="cell_px"):
        occupancy_grid(np.zeros((5, 5), np.uint8), cell_px=0)


@pytest.mark.parametrize(("name", "value"), [
    ("threshold", np.nan), ("threshold", 300), ("threshold", "100"), ("fill", "0.5"),
    ("fill", np.nan), ("fill", 1.0), ("min_area", np.nan), ("min_area", "20"), ("min_area", -1),
    ("cell_px", 2.0), ("cell_px", True), ("cell_px", 0), ("cell_px", 2**40),
])
def test_occupancy_grid_refuses_bad_numbers(name, value):
    img = np.zeros((20, 30), np.uint8)
    kw = {"cell_px": 4, name: value}
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        occupancy_grid(img, **kw)


def test_occupancy_grid_with_a_cell_larger_than_the_image():
    # the image used to be padded to whole cells: 74.5 GiB at cell_px=10**5
    img = np.zeros((20, 30), np.uint8)
    img[5:9, 5:9] = 255
    occ = occupancy_grid(img, cell_px=10**5, threshold=100, min_area=1)
    assert occ.grid.shape == (1, 1) and occ.grid[0, 0] and occ.cell_px == 10**5
    assert not occupancy_grid(img, cell_px=10**5, threshold=100, min_area=1, fill=0.5).grid[0, 0]


@pytest.mark.parametrize("name", ["start", "goal"])
@pytest.mark.parametrize("cell", [(0.5, 0), (0.0, 0.0), (3, 3.5), (True, 1), "ab", 5, (1, 2, 3),
                                  None, (np.nan, 1)])
def test_bfs_refuses_cells_that_are_not_integer_pairs(name, cell):
    kw = {"start": (0, 0), "goal": (3, 3), name: cell}
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        bfs_path(np.zeros((8, 8), bool), **kw)


def test_bfs_takes_numpy_integer_cells():
    path = bfs_path(np.zeros((4, 4), bool), np.array([0, 0]), (np.int64(0), np.int32(2)))
    assert path == [(0, 0), (0, 1), (0, 2)]


def test_occupancy_grid_of_an_image_smaller_than_min_area():
    img = np.full((1, 1), 255, np.uint8)
    assert not occupancy_grid(img, cell_px=4, threshold=100).grid.any()  # min_area 20 > 1 pixel
    assert occupancy_grid(img, cell_px=4, threshold=100, min_area=1).grid.all()
