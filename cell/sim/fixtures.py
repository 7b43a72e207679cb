"""Fixed furniture of the cell: the table, the bins and the checkerboard target.

The checkerboard is built from geoms (black squares on a white board), not a texture,
so the compiled model still exports to XML and its corners are exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from cell.sim import layout

__all__ = [
    "add_bins", "add_checkerboard", "add_table", "add_target", "checkerboard_corners",
    "target_corners_world",
]

_BOX = mujoco.mjtGeom.mjGEOM_BOX
_BOARD_THICKNESS = 0.004
_SQUARE_LIFT = 0.0002  # black squares sit this far above the white board (no z-fighting)


def add_table(spec: mujoco.MjSpec) -> None:
    """The table top: an infinite plane at z = 0 named ``table``."""
    mat = spec.add_material()
    mat.name = "table"
    mat.rgba = [0.62, 0.60, 0.56, 1]
    spec.worldbody.add_geom(
        name="table", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="table"
    )


def add_bins(spec: mujoco.MjSpec) -> None:
    """One open bin per class of ``layout.BINS`` (bodies ``bin_<class>``), floor + 4 walls."""
    sx, sy, h = layout.BIN_SIZE
    wall = 0.006
    colours = {"metal": [0.35, 0.45, 0.6, 1], "plastic": [0.7, 0.55, 0.2, 1],
               "reject": [0.7, 0.2, 0.2, 1]}
    for name, centre in layout.BINS.items():
        body = spec.worldbody.add_body(name=f"bin_{name}", pos=centre.tolist())
        rgba = colours[name]
        body.add_geom(name=f"bin_{name}_floor", type=_BOX, size=[sx / 2, sy / 2, wall / 2],
                      pos=[0, 0, wall / 2], rgba=rgba)
        for i, (dx, dy) in enumerate(((1, 0), (-1, 0), (0, 1), (0, -1))):
            size = [wall / 2, sy / 2 + wall, h / 2] if dx else [sx / 2 + wall, wall / 2, h / 2]
            pos = [dx * (sx / 2 + wall / 2), dy * (sy / 2 + wall / 2), h / 2]
            body.add_geom(name=f"bin_{name}_wall{i}", type=_BOX, size=size, pos=pos, rgba=rgba)


@dataclass(frozen=True)
class BoardBuild:
    """How :func:`add_checkerboard` builds a board: its ``thickness`` (m), the black
    squares' ``lift`` above the white face (m; no z-fighting), the z of its back face in the
    body's frame (``back``, m), the board's collision bits (``contype``, ``conaffinity``),
    and the ``white`` and ``black`` material names (None: plain white and black ``rgba``)."""

    thickness: float = _BOARD_THICKNESS
    lift: float = _SQUARE_LIFT
    back: float = 0.0
    contype: int = 1
    conaffinity: int = 1
    white: str | None = None
    black: str | None = None


def add_checkerboard(body, name: str, inner_corners: tuple[int, int], square: float, *,
                     build: BoardBuild = BoardBuild()) -> None:
    """A checkerboard in ``body``'s frame: a white board (geom ``<name>_board``) in the
    xy plane facing +z, with black squares (``<name>_sq_<i>_<j>``, drawn only) on it.

    ``inner_corners`` (nx, ny) inner corners means (nx + 1) x (ny + 1) squares of
    ``square`` metres, centred on the body's z axis, inside a white margin one square
    wide. The board's back face is at z = ``build.back``, its white face ``build.thickness``
    above, the black squares' tops ``build.lift`` above that (see :class:`BoardBuild`).
    """
    nx, ny = inner_corners
    s = square
    thickness, lift, back = build.thickness, build.lift, build.back
    contype, conaffinity, white, black = build.contype, build.conaffinity, build.white, build.black
    board = body.add_geom(name=f"{name}_board", type=_BOX,
                          size=[(nx + 3) * s / 2, (ny + 3) * s / 2, thickness / 2],
                          pos=[0, 0, back + thickness / 2], contype=contype,
                          conaffinity=conaffinity)
    if white is None:
        board.rgba = [0.95, 0.95, 0.95, 1]
    else:
        board.material = white
    z = back + thickness + lift / 2
    for i in range(nx + 1):
        for j in range(ny + 1):
            if (i + j) % 2:
                continue
            x = (i - nx / 2) * s
            y = (j - ny / 2) * s
            sq = body.add_geom(name=f"{name}_sq_{i}_{j}", type=_BOX,
                               size=[s / 2, s / 2, lift / 2], pos=[x, y, z],
                               contype=0, conaffinity=0)
            if black is None:
                sq.rgba = [0.03, 0.03, 0.03, 1]
            else:
                sq.material = black


def checkerboard_corners(inner_corners: tuple[int, int], square: float) -> np.ndarray:
    """Inner corners (N, 3) of a board of ``add_checkerboard`` in its corner plane
    (z = 0), row-major in x then y: the order ``cv2.findChessboardCorners`` gives for
    pattern size ``inner_corners`` when the board's x axis runs along the image rows."""
    nx, ny = inner_corners
    xs = (np.arange(nx) - (nx - 1) / 2) * square
    ys = (np.arange(ny) - (ny - 1) / 2) * square
    gx, gy = np.meshgrid(xs, ys)
    return np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)


def add_target(spec: mujoco.MjSpec) -> None:
    """The checkerboard (body ``target``) flat on the table at ``layout.TARGET_CENTRE``.

    ``TARGET_INNER_CORNERS`` = (8, 5) inner corners means 9 x 6 squares of
    ``TARGET_SQUARE`` metres, inside a white margin one square wide.
    """
    body = spec.worldbody.add_body(name="target", pos=layout.TARGET_CENTRE.tolist())
    add_checkerboard(body, "target", layout.TARGET_INNER_CORNERS, layout.TARGET_SQUARE)


def target_corners_world() -> np.ndarray:
    """World positions (N, 3) of the target's inner corners, row-major in x then y (metres).

    Ground truth of the board's geometry: for scoring and for building the object points
    a calibration uses (a real user knows their board's square size and layout too).
    The corners lie half the squares' lift above the white face: a black square stands
    ``_SQUARE_LIFT`` proud of it, and seen at a slant its side wall widens it on one side,
    so the edges a detector finds are those of its mid-height (on tool-down wrist-camera
    views rendered with ``msaa=4``, detected corners come within 0.087 px RMS of these,
    0.094 px of the top face's).
    """
    pts = checkerboard_corners(layout.TARGET_INNER_CORNERS, layout.TARGET_SQUARE)
    pts[:, 2] = _BOARD_THICKNESS + _SQUARE_LIFT / 2
    return pts + layout.TARGET_CENTRE
