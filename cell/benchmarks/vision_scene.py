"""The vision bench's scenes: every part of a world placed in the overhead camera's view,
about a third of them touching a neighbour in the image (not stacked by the physics).

A touching part goes along a random direction from the previous one, at the distance
where their top-view footprints (rasterised at 0.1 mm) just meet, plus 0.3 mm. The
footprints are the kinds' outlines as :mod:`cell.sim.parts` builds them.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from cell.catalogue import KINDS

__all__ = ["place_scene"]

_VIEW_X = 0.165  # half-range of part centres along the belt around the pick zone (m)
_VIEW_Y = 0.045  # half-range across the belt (m)


def _outline(kind: str) -> list[np.ndarray]:
    """Top-view polygons (metres, body frame) of a kind, as cell.sim.parts builds it (the
    bolt's shaft starts 0.1 mm nearer the head than there: kept, so that the bench's scenes,
    whose touching parts stand 0.3 mm apart by these outlines, stay those of its tables)."""
    t = np.linspace(0, 2 * math.pi, 48, endpoint=False)
    ring = np.stack([np.cos(t), np.sin(t)], axis=1)
    if kind in ("washer", "disc"):
        return [ring * KINDS[kind].length / 2]
    if kind == "hex_nut":
        a = np.arange(6) * math.pi / 3
        return [np.stack([np.cos(a), np.sin(a)], axis=1) * 0.0085 / math.cos(math.pi / 6)]
    if kind == "square_nut":
        return [np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * 0.0065]

    def box(cx, cy, hx, hy):
        return np.array([[cx - hx, cy - hy], [cx + hx, cy - hy], [cx + hx, cy + hy],
                         [cx - hx, cy + hy]])

    if kind == "bolt":
        return [box(0.0034, 0, 0.020, 0.003), box(-0.0186, 0, 0.002, 0.00575)]
    d = 0.004345  # l_bracket
    return [box(d, -0.015 + 0.006 + d, 0.020, 0.006), box(-0.020 + 0.006 + d, d, 0.006, 0.015)]


def _overlap(kind_a, pose_a, kind_b, pose_b) -> bool:
    """Whether two parts' top-view footprints overlap (rasterised at 0.1 mm)."""
    res, half = 1e-4, 0.06
    cx, cy = (pose_a[0] + pose_b[0]) / 2, (pose_a[1] + pose_b[1]) / 2
    size = int(2 * half / res)
    masks = []
    for kind, (x, y, yaw) in ((kind_a, pose_a), (kind_b, pose_b)):
        m = np.zeros((size, size), np.uint8)
        c, s_ = math.cos(yaw), math.sin(yaw)
        for poly in _outline(kind):
            pts = poly @ np.array([[c, s_], [-s_, c]]) + [x - cx + half, y - cy + half]
            cv2.fillPoly(m, [np.round(pts / res).astype(np.int32)], 255)
        masks.append(m)
    return cv2.countNonZero(cv2.bitwise_and(masks[0], masks[1])) > 0


def _touching_pose(kind_a, pose_a, kind_b, yaw_b, direction) -> tuple[float, float]:
    """Where part b goes, along ``direction`` from a, so their footprints just touch."""
    lo, hi = 0.0, KINDS[kind_a].half_diagonal + KINDS[kind_b].half_diagonal + 0.002
    ux, uy = math.cos(direction), math.sin(direction)
    for _ in range(14):  # bisection to ~0.01 mm
        mid = (lo + hi) / 2
        pose = (pose_a[0] + mid * ux, pose_a[1] + mid * uy, yaw_b)
        lo, hi = (mid, hi) if _overlap(kind_a, pose_a, kind_b, pose) else (lo, mid)
    d = hi + 0.0003  # a hair apart: they touch in the image, do not stack in the physics
    return pose_a[0] + d * ux, pose_a[1] + d * uy


def place_scene(world, rng: np.random.Generator, layout) -> list[int]:
    """Place every part of the world in view; about a third of them touch a neighbour.

    A touching part is placed along a random direction from the previous one at the
    distance where their top-view footprints just meet (plus 0.3 mm), so pairs touch in
    the image without being stacked by the physics.
    """
    centre = layout.PICK_ZONE
    placed: list[tuple[str, float, float, float]] = []  # kind, x, y, yaw
    ids = []
    for part in world.parts:
        r = KINDS[part.kind].half_diagonal
        for _ in range(200):
            yaw = rng.uniform(0, 2 * math.pi)
            if placed and rng.random() < 0.35:  # touch the previous part
                pk, px, py, pyaw = placed[-1]
                x, y = _touching_pose(pk, (px, py, pyaw), part.kind, yaw, rng.uniform(0, 2 * math.pi))
                others = placed[:-1]
            else:
                x = centre[0] + rng.uniform(-_VIEW_X, _VIEW_X)
                y = centre[1] + rng.uniform(-_VIEW_Y, _VIEW_Y)
                others = placed
            inside = abs(x - centre[0]) <= _VIEW_X + 0.01 and abs(y - centre[1]) <= _VIEW_Y + 0.005
            if inside and all(math.hypot(x - ox, y - oy) > r + KINDS[ok].half_diagonal + 0.004
                              for ok, ox, oy, _ in others):
                break
        world.place_next_part(x, y, yaw)
        placed.append((part.kind, x, y, yaw))
        ids.append(part.id)
    for _ in range(150):  # settle: parts come to rest, the belt running while no part
        world.conveyor.proceed()  # breaks the barrier (no latch: a scene is no cycle of
        world.step(1)  # the sort job, and every table was measured on these frames)
    return ids
