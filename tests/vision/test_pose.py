"""The compiled yaw and bolt reference point (cell.vision._pose) against their numpy and
OpenCV formulation, on the catalogue's outlines turned, shifted and jittered. On this
project's machines they agree bit for bit (the kernels round products as numpy's matrix
product does there: fused multiply-add); the tests allow 1e-12, so a numpy that rounds
differently does not fail them."""

from __future__ import annotations

import math

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.catalogue import KINDS
from cell.vision._footprint import bolt_origin
from cell.vision._pose import (
    CUT_GUARD,
    RECTANGLE,
    bolt_point,
    detection_poses,
    flat_angle,
    second_moment_angle,
)
from cell.vision.kind import YAW_CODES, Footprint, footprint, footprint_yaw, outline_yaw
from tests.vision.test_kind import OUTLINES, _turn


def _flat(outline: np.ndarray, n: int, kappa: float, cut: int = 0) -> float:
    p = np.ascontiguousarray(outline, dtype=np.float64)
    skip = min(cut + 2 * CUT_GUARD, len(p) // 2) if cut else 0
    return flat_angle(p, n, 5, kappa, 2, len(p) - cut - CUT_GUARD, skip)


def _bracket_yaw(fp: Footprint) -> float:
    a = fp.rect_angle
    off = (_flat(fp.outline, 4, 2.0) - a + math.pi / 4) % (math.pi / 2) - math.pi / 4
    if abs(off) > math.radians(2.0):
        a += off
    u = np.array([math.cos(a), math.sin(a)])
    s = (fp.outline - fp.centroid) @ u
    su = 1.0 if s.max() > -s.min() else -1.0
    long_dir = su * u
    return float(math.atan2(long_dir[1], long_dir[0]))


def _second_moment_angle(outline: np.ndarray) -> float:
    m = cv2.moments(((outline - outline[0]) * 1e3).astype(np.float32))
    return 0.5 * math.atan2(2 * m["mu11"], m["mu20"] - m["mu02"])


def _yaw(fp: Footprint, kind: str, cut: int) -> float:
    """footprint_yaw as numpy (and OpenCV) computed it."""
    if kind == "bolt":
        return float(_second_moment_angle(fp.outline) % math.pi)
    if kind == "hex_nut":
        yaw = _flat(fp.outline, 6, 1.0, cut) - math.pi / 6
        return float(yaw % (2 * math.pi / 6))
    if kind == "square_nut":
        return float(_flat(fp.outline, 4, 2.0, cut) % (2 * math.pi / 4))
    return float(_bracket_yaw(fp) % (2 * math.pi))


def _bolt_origin(fp: Footprint) -> np.ndarray:
    axis = np.array([math.cos(fp.rect_angle), math.sin(fp.rect_angle)])
    rel = fp.outline - fp.centroid
    s = rel @ axis
    t = rel @ np.array([-axis[1], axis[0]])
    s_max, s_min = float(s.max()), float(s.min())
    w_max = float(np.abs(t[s > s_max - 0.004]).max())
    w_min = float(np.abs(t[s < s_min + 0.004]).max())
    to_head = 1.0 if w_max > w_min else -1.0
    mid = 0.5 * (s_max + s_min) + to_head * 0.0014
    return fp.centroid + mid * axis


def _jittered(kind: str, yaw: float, dx: float, dy: float, seed: int) -> np.ndarray:
    outline = _turn(OUTLINES[kind][0], yaw, at=(0.3 + dx, 0.45 + dy))
    return outline + np.random.default_rng(seed).normal(0.0, 2e-4, outline.shape)


pose = (st.floats(0, 2 * math.pi), st.floats(-0.2, 0.2), st.floats(-0.2, 0.2),
        st.integers(0, 2**31))


@settings(max_examples=120, deadline=None)
@given(st.sampled_from(["hex_nut", "square_nut", "l_bracket", "bolt"]), *pose, st.integers(0, 30))
def test_yaw_is_the_numpy_formulation(kind, yaw, dx, dy, seed, cut):
    fp = footprint(_jittered(kind, yaw, dx, dy, seed))
    cut = cut if kind in ("hex_nut", "square_nut") else 0
    period = {"hex_nut": math.pi / 3, "square_nut": math.pi / 2, "bolt": math.pi}.get(kind, 2 * math.pi)
    d = (footprint_yaw(fp, kind, cut=cut) - _yaw(fp, kind, cut)) % period
    assert min(d, period - d) < 1e-12


@settings(max_examples=120, deadline=None)
@given(*pose)
def test_bolt_origin_is_the_numpy_formulation(yaw, dx, dy, seed):
    fp = footprint(_jittered("bolt", yaw, dx, dy, seed))
    np.testing.assert_allclose(bolt_origin(fp), _bolt_origin(fp), rtol=0, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05)), min_size=3,
                max_size=200), st.floats(-0.5, 0.5), st.floats(-0.5, 0.5))
def test_second_moments_are_opencvs(pts, dx, dy):
    p = np.array(pts) + (dx, dy)
    assert second_moment_angle(p) == _second_moment_angle(p)



def test_detection_poses_are_each_detections_yaw_and_position():
    kinds = ["hex_nut", "square_nut", "l_bracket", "bolt", "bolt", "washer", "unknown"]
    rng = np.random.default_rng(5)
    fps, rows = [], []
    for i, kind in enumerate(kinds):
        fp = footprint(_jittered(kind if kind in OUTLINES else "hex_nut",
                                 float(rng.uniform(0, 6)), 0.01 * i, -0.02 * i, i))
        cut = 7 if kind == "hex_nut" else 0
        known = kind in KINDS
        partial = i == 4  # a bolt at the border: no position
        rows.append((fp.centroid[0], fp.centroid[1], fp.rect_angle,
                     YAW_CODES.get(kind, RECTANGLE) if known else -1,
                     KINDS[kind].symmetry if known else 0, cut, kind == "bolt" and not partial))
        fps.append((fp, kind, cut, partial))
    outlines = [fp.outline for fp, *_ in fps]
    starts = np.concatenate([[0], np.cumsum([len(o) for o in outlines])]).astype(np.int64)
    yaw, xy = np.empty(len(kinds)), np.empty((len(kinds), 2))
    detection_poses(np.concatenate(outlines), starts, np.array(rows, np.float64), yaw, xy)
    for d, (fp, kind, cut, partial) in enumerate(fps):
        assert yaw[d] == (outline_yaw(fp.outline, *fp.centroid, fp.rect_angle, kind, cut)
                          if kind in KINDS else 0.0)
        if kind == "bolt" and not partial:
            assert tuple(xy[d]) == bolt_point(np.ascontiguousarray(fp.outline), *fp.centroid,
                                              fp.rect_angle)
        else:
            assert tuple(xy[d]) == tuple(fp.centroid)
