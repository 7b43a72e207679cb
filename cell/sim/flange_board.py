"""The flange board: an optional checkerboard plate on the tool, the target of the
overhead camera's eye-to-hand calibration.

Mounting. A light plate on a short bracket on the side of the tool housing, its board
face turned away from the tool axis: the plate lies in the plane ``x = -FACE_OFFSET`` of
the flange frame (parallel to the flange's y and z axes), facing the flange's -x, so
the board's normal is perpendicular to the tool (approach) axis. Held with the tool
axis level and the flange's -x pointing up, the board lies flat and faces up into the
overhead camera; turning the wrist tilts it and turns it about its normal. Why the side
and not the end: the overhead camera looks down at the belt from 0.40 m, so the board
must face up while the arm stays clear of the belt under it; a board facing along the
tool axis would need the tool to point up, the wrist under the board, next to the
belt. Why -x: the wrist camera sits at the flange's +y and would hang under a board on
the -y side; on the -x side it lies beside the tool, so the tool's lowest point is its
housing, 0.11 m under the board's face. ``FACE_OFFSET`` keeps the plate just outside the
wrist camera's view (its half-angle across the plate is 31.9 deg; the plate's back is
seen at 32.7 deg at the most): wrist images are the same with and without it. The plate
is clear of the cup; it reaches ``PLATE_REACH`` past the flange along the tool axis,
just past the cup face: with the plate on, the arm does not pick parts.

Board frame (``T_flange_board``), OpenCV's: origin at the centre of the inner corners,
``LIFT / 2`` above the white face (where the squares' edges are seen: a black square
stands ``LIFT`` proud of the white, and seen at a slant its side wall widens it on one
side); x along the plate's long side (the flange's +y), y along the tool axis (the
flange's +z), z into the board (the flange's +x, away from a viewer of its face).
``board_corners`` lists the inner corners row-major in x then y, the order in which
``cv2.findChessboardCorners(image, INNER_CORNERS)`` returns them on the overhead
camera's views (checked over the poses of ``cell.sim.board_poses``), so detected corner
k is ``board_corners()[k]``. ``INNER_CORNERS`` = (8, 5) inner corners of ``SQUARE``
metres (9 x 6 squares) inside a white margin one square wide, as the table's target but
smaller; black squares on white, matte (no specular highlight at any tilt).

The plate is its own body ``flange_board`` (``arm/flange_board`` in the world) under the
tool body, ``MASS`` kg (an aluminium-composite sheet), gravity compensated like every
arm body; its plate collides with the cell's furniture (not with the arm). Being a
separate body, it takes no part in the suction actuator's adhesion (which acts on the
tool body's contacts). Without the option the arm is built exactly as before.
"""

from __future__ import annotations

import mujoco
import numpy as np

from cell.sim.fixtures import BoardBuild, add_checkerboard, checkerboard_corners

__all__ = [
    "BODY",
    "INNER_CORNERS",
    "MASS",
    "PLATE_GEOM",
    "PLATE_SIZE",
    "SQUARE",
    "T_flange_board",
    "add_flange_board",
    "board_corners",
    "corners_in_flange",
]

INNER_CORNERS = (8, 5)  # even x odd: cv2.findChessboardCorners orders it without ambiguity
SQUARE = 0.015  # edge of one square (m)
THICKNESS = 0.004  # plate thickness (m)
LIFT = 0.00002  # black squares stand this far above the white face (m): no z-fighting
FACE_OFFSET = 0.065  # the white face's distance from the tool axis (m)
PLATE_START = 0.005  # the plate's edge nearest the flange, along the tool axis (m)
MASS = 0.09  # kg: a 3 mm aluminium-composite sheet (3.8 kg/m^2) and its bracket
PLATE_SIZE = ((INNER_CORNERS[0] + 3) * SQUARE, (INNER_CORNERS[1] + 3) * SQUARE)  # x, y (m)
PLATE_REACH = PLATE_START + PLATE_SIZE[1]  # plate's far edge past the flange (m)
BODY = "flange_board"
PLATE_GEOM = "flange_board_board"

# The plate's body frame ("face frame") in the flange frame: x = flange -y, y = flange z,
# z = flange -x (out of the face); the board frame is it turned half a turn about its y.
_R_FLANGE_FACE = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
_R_FACE_BOARD = np.diag([-1.0, 1.0, -1.0])
_ORIGIN = np.array([-(FACE_OFFSET + LIFT / 2), 0.0, PLATE_START + PLATE_SIZE[1] / 2])


def T_flange_board() -> np.ndarray:
    """GROUND TRUTH, for scoring only: the board frame in the flange frame (4x4, metres).

    The unknown an eye-to-hand calibration solves for, besides the camera's pose.
    """
    T = np.eye(4)
    T[:3, :3] = _R_FLANGE_FACE @ _R_FACE_BOARD
    T[:3, 3] = _ORIGIN
    return T


def board_corners() -> np.ndarray:
    """The board's inner corners (N, 3) in the board frame (z = 0), metres, row-major in
    x then y: a calibration's object points (a user knows their board's layout)."""
    return checkerboard_corners(INNER_CORNERS, SQUARE)


def corners_in_flange() -> np.ndarray:
    """GROUND TRUTH, for scoring only: the inner corners (N, 3) in the flange frame (m)."""
    T = T_flange_board()
    return board_corners() @ T[:3, :3].T + T[:3, 3]


def _matte(spec: mujoco.MjSpec, name: str, grey: float) -> str:
    mat = spec.add_material()
    mat.name = name
    mat.rgba = [grey, grey, grey, 1.0]
    mat.specular = 0.0
    mat.shininess = 0.0
    mat.reflectance = 0.0
    return name


def add_flange_board(spec: mujoco.MjSpec, tool, *, contype: int, conaffinity: int) -> None:
    """Add the plate (body ``BODY``, its frame on the board's corner plane, z out of the
    face) to the arm's ``tool`` body (frame = the flange's)."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, _R_FLANGE_FACE.ravel())
    body = tool.add_body(name=BODY, pos=_ORIGIN.tolist(), quat=quat.tolist())
    w, h = PLATE_SIZE
    body.explicitinertial = True
    body.mass = MASS
    back = -(THICKNESS + LIFT / 2)
    body.ipos = [0.0, 0.0, back + THICKNESS / 2]
    body.inertia = [MASS * (h**2 + THICKNESS**2) / 12, MASS * (w**2 + THICKNESS**2) / 12,
                    MASS * (w**2 + h**2) / 12]
    body.gravcomp = 1.0
    white = _matte(spec, "flange_board_white", 0.95)
    black = _matte(spec, "flange_board_black", 0.03)
    add_checkerboard(body, "flange_board", INNER_CORNERS, SQUARE,
                     build=BoardBuild(thickness=THICKNESS, lift=LIFT, back=back, contype=contype,
                                      conaffinity=conaffinity, white=white, black=black))
    # The bracket: from the tool housing (radius 0.03 about the tool axis) to the plate's
    # back, along the housing. In the face frame the tool axis is at z = -(FACE_OFFSET +
    # LIFT / 2) and runs along y. (The pattern is symmetric under x -> -x: 9 squares a row.)
    axis_z = -(FACE_OFFSET + LIFT / 2)
    b0, b1 = axis_z + 0.028, back  # board-frame z of the housing side and the plate back
    y0 = -_ORIGIN[2]  # the flange plane in board y
    body.add_geom(name="flange_board_bracket", type=mujoco.mjtGeom.mjGEOM_BOX,
                  size=[0.015, 0.025, (b1 - b0) / 2], pos=[0.0, y0 + 0.035, (b0 + b1) / 2],
                  rgba=[0.15, 0.15, 0.17, 1.0], contype=contype, conaffinity=conaffinity)
