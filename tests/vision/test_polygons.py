"""The compiled footprint descriptors against OpenCV, and the compiled kind fit against
its definition (scores of the footprints it returns)."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.camera import CameraModel
from cell.catalogue import KINDS
from cell.vision._blob import Blob, outline_normals
from cell.vision._footprint import Geometry, fit_kinds
from cell.vision._polygons import describe_polygons, plane_rays, polygon_area
from cell.vision.kind import classify_kind, footprint, score_kind
from tests.vision.test_kind import OUTLINES, _turn  # the exact catalogue outlines


def _star(radii: list[float], centre=(0.3, 0.45), turn=0.0) -> np.ndarray:
    """A star-shaped (simple) polygon in metres: radius r_k at evenly spaced angles."""
    t = turn + np.arange(len(radii)) * 2 * math.pi / len(radii)
    r = np.asarray(radii)
    return np.stack([centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)], axis=1)


radii = st.lists(st.floats(0.004, 0.03), min_size=5, max_size=60)


@settings(max_examples=60, deadline=None)
@given(radii, st.floats(0, 2 * math.pi), st.booleans())
def test_descriptors_match_opencv(rs, turn, with_hole):
    outline = _star(rs, turn=turn)
    hole = _star([0.6 * min(rs)] * 24) if with_hole else None
    polys = [outline] + ([hole] if with_hole else [])
    starts = np.concatenate(([0], np.cumsum([len(p) for p in polys])))
    d = describe_polygons(np.concatenate(polys), starts, np.zeros(1, np.intp))

    mm = ((outline - outline[0]) * 1e3).astype(np.float32)
    m = cv2.moments(mm)
    area = abs(m["m00"])
    cx, cy = m["m10"] / m["m00"], m["m01"] / m["m00"]
    if with_hole:
        mh = cv2.moments(((hole - outline[0]) * 1e3).astype(np.float32))
        cx = (area * cx - abs(mh["m00"]) * mh["m10"] / mh["m00"]) / (area - abs(mh["m00"]))
        cy = (area * cy - abs(mh["m00"]) * mh["m01"] / mh["m00"]) / (area - abs(mh["m00"]))
        area_net = area - abs(mh["m00"])
    else:
        area_net = area
    assert d.outer[0] == pytest.approx(area * 1e-6, rel=1e-5)
    assert d.area[0] == pytest.approx(area_net * 1e-6, rel=1e-5)
    np.testing.assert_allclose(d.centroid[0], outline[0] + np.array([cx, cy]) * 1e-3, atol=1e-8)
    (_, _), (w, h), _ = cv2.minAreaRect(mm)
    assert d.length[0] * d.width[0] == pytest.approx(w * h * 1e-6, rel=1e-4)
    # (two orientations may give the same area: check ours encloses the polygon)
    u = np.array([math.cos(d.rect_angle[0]), math.sin(d.rect_angle[0])])
    along, across = outline @ u, outline @ np.array([-u[1], u[0]])
    assert np.ptp(along) <= d.length[0] + 1e-9 and np.ptp(across) <= d.width[0] + 1e-9
    hull_area = cv2.contourArea(cv2.convexHull(mm))
    assert d.solidity[0] == pytest.approx(area / hull_area, rel=1e-4)
    assert polygon_area(mm.astype(np.float64)) == pytest.approx(cv2.contourArea(mm), rel=1e-6)


def test_rectangle_angle_and_facets():
    rect = np.array([[0, 0], [0.04, 0], [0.04, 0.01], [0, 0.01]], float)
    c, s = math.cos(0.3), math.sin(0.3)
    rect = rect @ np.array([[c, s], [-s, c]])
    d = describe_polygons(rect, np.array([0, 4]), np.zeros(1, np.intp))
    assert d.length[0] == pytest.approx(0.04) and d.width[0] == pytest.approx(0.01)
    assert math.cos(2 * (d.rect_angle[0] - 0.3)) == pytest.approx(1.0)
    hexagon = _star([0.01] * 6)
    circle = _star([0.01] * 200)
    polys = np.concatenate([hexagon, circle])
    d = describe_polygons(polys, np.array([0, 6, 206]), np.array([0, 1]))
    assert d.facets6[0] == pytest.approx(1.0)
    assert d.facets6[1] < 0.01


def _camera() -> CameraModel:
    K = np.array([[660.0, 0, 319.5], [0, 660.0, 239.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = (0.0, 0.45, 0.48)
    return CameraModel(640, 480, K, np.zeros(5), T)


def _blob_of(kind: str, yaw: float, at=(0.02, 0.44)):
    """A blob whose outline is the catalogue kind's top-view outline, projected through
    the camera from the heights the kind's edges have (as the detector assumes)."""
    cam = _camera()
    outline, holes = OUTLINES[kind]
    polys = [_turn(outline, yaw, at)] + [_turn(h, yaw, at) for h in holes]
    h = KINDS[kind].height
    px = []
    for p in polys:  # dense pixel outline: the top edge (the far side sees it) as the image shows
        dense = np.concatenate([np.linspace(a, b, 12, endpoint=False)
                                for a, b in zip(p, np.roll(p, -1, axis=0), strict=True)])
        world = np.c_[dense, np.full(len(dense), 0.08 + 0.5 * h)]
        px.append(cam.project(world))
    contour, normals = outline_normals(px[0], hole=False)
    hole_list = [outline_normals(q, hole=True) for q in px[1:]]
    box = cv2.boundingRect(contour.astype(np.float32))
    return Blob(contour, normals, hole_list, box, False)


@pytest.mark.parametrize("kind", [k for k in KINDS if k != "bolt"])
def test_fit_kinds_names_catalogue_outlines_and_agrees_with_its_scores(kind):
    geo = Geometry(_camera(), 0.08)
    blobs = [_blob_of(kind, yaw) for yaw in (0.2, 1.1)]
    fits = fit_kinds(blobs, geo, 0.5)
    for name, conf, fit, res in fits:
        assert name == kind and conf > 0.8
        fp = res.fp
        # the footprint returned is the one scored: its own descriptors give the fit
        again = footprint(fp.outline, fp.holes)
        assert score_kind(again, kind) == pytest.approx(fit, rel=1e-6, abs=1e-9)
        label, _, _ = classify_kind({k: score_kind(again, k) for k in KINDS})
        assert label in (kind, "unknown") or fit < 16
        np.testing.assert_allclose(fp.centroid, (0.02, 0.44), atol=1.5e-3)


def test_plane_rays_meet_the_plane_where_the_camera_model_projects():
    cam = _camera()
    world = np.array([[0.0, 0.45, 0.08], [0.1, 0.40, 0.08], [-0.12, 0.5, 0.08]])
    uv = cam.project(world)
    rays, away = plane_rays(uv, np.zeros_like(uv), None, cam.K, cam.T_world_camera[:3, :3], None)
    o = cam.T_world_camera[:3, 3]
    np.testing.assert_allclose(o[:2] + (0.08 - o[2]) * rays, world[:, :2], atol=1e-9)
    assert not away.any()


@settings(max_examples=40, deadline=None)
@given(radii, st.floats(-0.05, 0.05), st.floats(-0.05, 0.05))
def test_point_in_piece_matches_opencv(rs, dx, dy):
    """The cut stage's point-in-polygon test (outline runs, then cut points) against
    cv2.pointPolygonTest."""
    from cell.vision._cutfit import _inside

    poly = _star(rs, centre=(0.0, 0.0)) * 1e3  # pixels-ish
    k = len(poly)
    runs = np.arange(0, k - 2)
    cut = poly[k - 2 :]
    p = (float(dx * 1e3), float(dy * 1e3))
    expect = cv2.pointPolygonTest(poly.astype(np.float32), p, True)
    if abs(expect) > 1e-3:  # off the boundary
        assert _inside(p[0], p[1], poly, runs, cut) == (expect > 0)
