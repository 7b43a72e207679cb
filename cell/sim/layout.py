"""Where everything stands in the cell (world frame, metres; z up, table top at z = 0).

One place for the numbers the world builder, the robot and the tests share. The arm's
base is the world origin; the conveyor runs along +x at ``CONVEYOR_Y``; parts are picked
at ``PICK_ZONE``; bins stand on the other side of the arm.
"""

from __future__ import annotations

import numpy as np

ARM_BASE = np.array([0.0, 0.0, 0.0])

CONVEYOR_Y = 0.45  # centre line of the belt
BELT_TOP = 0.08  # height of the belt surface
BELT_X = (-0.80, 0.30)  # belt extent along x
BELT_WIDTH = 0.16
SPAWN_X = -0.72  # where parts are dropped onto the belt
BARRIER_X = 0.015  # the light barrier crosses the belt here
PICK_ZONE = np.array([0.0, CONVEYOR_Y, BELT_TOP])

# The catch zone past the belt's end: a part carried off the end falls towards the catch bin
# under it, and once its centre has dropped CATCH_DROP below the belt's top while past the
# end (within CATCH_HALF_WIDTH of the belt's centre line) it counts as caught and is parked
# off stage, out of the contact set. The bin itself (inner size CATCH_BIN_SIZE, rim below
# the catch line) is scenery: nothing ever rests in it.
CATCH_DROP = 0.02
CATCH_HALF_WIDTH = 0.15
CATCH_BIN_SIZE = (0.18, 0.24, BELT_TOP - CATCH_DROP - 0.008)  # inner x, y extent, wall height

OVERHEAD_CAMERA_HEIGHT = 0.40  # above the belt surface, looking straight down

BIN_SIZE = (0.16, 0.16, 0.08)  # inner x, y extent and wall height
BINS = {
    "metal": np.array([0.35, -0.28, 0.0]),
    "plastic": np.array([0.0, -0.42, 0.0]),
    "reject": np.array([-0.35, -0.28, 0.0]),
}

TARGET_CENTRE = np.array([0.50, 0.05, 0.0])  # checkerboard lies flat on the table here
TARGET_INNER_CORNERS = (8, 5)  # even x odd, as OpenCV's detector likes
TARGET_SQUARE = 0.025  # edge of one square (m)

TIMESTEP = 0.002  # physics step (s)
