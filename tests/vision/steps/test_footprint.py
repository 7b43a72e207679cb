"""Step 3a: footprints on the table plane and their descriptors."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.camera import CameraModel
from cell.errors import VisionError
from cell.vision.geometry import pixel_to_table
from cell.vision.steps.footprint import TablePlane, describe
from cell.vision.steps.outlines import outline_of_mask
from tests.vision.steps import drawn


def _polygon(n: int, radius: float, turn: float = 0.0, centre=(0.0, 0.0)) -> np.ndarray:
    a = turn + np.arange(n) * 2 * np.pi / n
    return np.stack([centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a)], 1)


def test_rectangle_descriptors():
    x, y = 0.1, 0.45
    rect = np.array([[x, y], [x + 0.02, y], [x + 0.02, y + 0.01], [x, y + 0.01]])
    fp = describe(rect)
    assert (fp.length, fp.width) == pytest.approx((0.02, 0.01), abs=1e-7)
    assert fp.area == pytest.approx(2e-4, rel=1e-5)
    assert fp.centroid == pytest.approx((x + 0.01, y + 0.005), abs=1e-8)
    assert fp.solidity == pytest.approx(1.0) and fp.hole_fraction == 0.0
    assert math.cos(2 * fp.rect_angle) == pytest.approx(1.0, abs=1e-6)  # along x


def test_ring_hole_fraction_and_facets():
    washer = describe(_polygon(96, 0.010), (_polygon(96, 0.00525),))
    assert washer.hole_fraction == pytest.approx(0.2756, abs=0.003)
    assert washer.facets6 < 0.05
    hexagon = describe(_polygon(6, 0.0098, turn=0.3))
    assert hexagon.facets6 == pytest.approx(1.0, abs=1e-6)


@settings(max_examples=40, deadline=None)
@given(st.floats(-0.12, 0.12), st.floats(0.40, 0.50), st.floats(0, 0.01),
       st.sampled_from([0.0, -0.2]))
def test_plane_points_equal_pixel_to_table(x, y, height, k1):
    cam = drawn.camera()
    cam = CameraModel(cam.width, cam.height, cam.K, np.array([k1, 0.0, 0.0, 0.0, 0.0]),
                      cam.T_world_camera)
    plane = TablePlane(cam, 0.08)
    uv = np.array([[100.5, 80.25], [320.0, 240.0], [600.0, 400.0]]) + np.array([x, y - 0.45]) * 100
    want = pixel_to_table(cam, uv, z=0.08 + height)[:, :2]
    np.testing.assert_allclose(plane.points(uv, height), want, atol=1e-9)


def test_top_edges_face_away_from_the_nadir():
    plane = TablePlane(drawn.camera(), 0.08)
    pts = np.array([[500.0, 240.0], [500.0, 240.0]])
    rays = plane.rays(pts, np.array([[1.0, 0.0], [-1.0, 0.0]]))  # right of the nadir
    assert rays.away.tolist() == [True, False]
    assert plane.m_per_px == pytest.approx(1 / (drawn.PX_PER_MM * 1e3), rel=1e-9)


@pytest.mark.parametrize(("R", "z"), [
    (np.eye(3), 0.5),  # looks up: its rays meet the plane behind it
    ([[1, 0, 0], [0, 0, 1], [0, -1, 0]], 0.5),  # looks along the plane
    ([[1, 0, 0], [0, -1, 0], [0, 0, -1]], -0.5),  # looks down from below the plane
], ids=["looks up", "along the plane", "below the plane"])
def test_a_camera_that_does_not_look_down_on_the_plane_is_a_vision_error(R, z):
    cam = drawn.camera()
    T = cam.T_world_camera.copy()
    T[:3, :3], T[2, 3] = R, z
    with pytest.raises(VisionError, match=r"^camera model: at z = .* m with its optical axis's z "
                       r".*: it must be above the plane z = 0.08 m \(vision.plane_z\) and look down "):
        TablePlane(CameraModel(cam.width, cam.height, cam.K, cam.dist, T), 0.08)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize(("R", "dist"), [
    ([[1, 0, 0], [0, -1, 0], [0, 0, -1]], [0.0, 0.0, 0.0, -100.0, 0.0]),  # folds the image there
], ids=["folding distortion"])
def test_a_camera_without_rays_at_its_principal_point_is_a_vision_error(R, dist):
    cam = drawn.camera()
    T = cam.T_world_camera.copy()
    T[:3, :3] = R
    K = np.array([[5.0, 0.0, 0.0], [0.0, 0.65, -cam.height], [0.0, 0.0, 1.0]]) if any(dist) else cam.K
    cam = CameraModel(cam.width, cam.height, K, np.array(dist), T)
    with pytest.raises(VisionError, match=r"^camera model: its rays at the principal point \(.*\) meet "
                       r"the plane z = 0.08 m nan m apart per pixel: it must look at the plane"):
        TablePlane(cam, 0.08)


@pytest.mark.parametrize("outline, holes, culprit", [
    (np.zeros((0, 2)), (), "argument 'outline'"),
    (np.array([[0, 0], [np.nan, 0], [0, 1.0]]), (), "argument 'outline'"),
    ("abc", (), "argument 'outline'"),
    (np.zeros((3, 2)), (), "argument 'outline' encloses no area"),
    (np.array([[0, 0], [1, 1], [2, 2.0]]), (), "argument 'outline' encloses no area"),
    (_polygon(6, 0.01), (np.zeros((2, 2)),), "argument 'holes'"),
    (_polygon(6, 0.01), np.zeros((6, 2)), "argument 'holes' must be a tuple"),
])
def test_describe_refuses_what_is_no_polygon(outline, holes, culprit):
    with pytest.raises(VisionError, match=culprit):
        describe(outline, holes)


def test_describe_of_a_tiny_polygon_is_not_refused():
    fp = describe(_polygon(6, 1e-7))
    assert fp.length == pytest.approx(2e-7, rel=1e-3)


def _folding_camera() -> CameraModel:
    """The drawn camera with k1 = -2: its lens model folds the image 0.41 (normalised) from
    the centre; past about 0.27 of distorted radius no point maps to a pixel at all."""
    cam = drawn.camera()
    return CameraModel(cam.width, cam.height, cam.K, np.array([-2.0, 0, 0, 0, 0]), cam.T_world_camera)


def test_a_pixel_the_lens_model_has_no_ray_for_gets_none():
    # (the undistortion stopped anywhere: a finite, wrong point, that projects elsewhere)
    cam = _folding_camera()
    plane = TablePlane(cam, 0.08)
    near, far = np.array([[330.0, 250.0]]), np.array([[31.7, 285.2], [0.0, 0.0]])
    assert np.isfinite(plane.points(near, 0.0)).all()
    assert np.isnan(plane.points(far, 0.0)).all()
    back = cam.project(np.c_[plane.points(near, 0.0), [0.08]])
    assert back == pytest.approx(near, abs=1e-6)
    with pytest.raises(VisionError, match=r"pixel \(31.7, 285.2\) has no ray"):
        pixel_to_table(cam, far, z=0.08)


def test_every_pixel_of_a_wide_lens_that_folds_nothing_has_a_ray():
    # (cv2.undistortPointsIter stops up to 0.1 px short in the corners: a 0.01 px round
    # trip called 1,974 such pixels rayless)
    cam = drawn.camera()
    K = np.array([[300.0, 0, 319.5], [0, 300.0, 239.5], [0, 0, 1]])
    wide = CameraModel(cam.width, cam.height, K, np.array([-0.3, 0.1, 0, 0, 0]), cam.T_world_camera)
    u, v = np.meshgrid(np.arange(0, 640, 16.0), np.arange(0, 480, 16.0))
    pixels = np.c_[u.ravel(), v.ravel()]
    assert np.isfinite(TablePlane(wide, 0.08).points(pixels, 0.0)).all()
    assert np.isfinite(pixel_to_table(wide, pixels, z=0.08)).all()


def test_blob_area_in_mm2_is_the_pixel_area_times_the_squared_scale():
    """A disc of radius r px drawn at the image centre covers about pi (r / px_per_mm)^2
    mm^2 on the table (the scale squared, not the scale)."""
    cam = drawn.camera()
    mask = np.zeros((cam.height, cam.width), np.uint8)
    cv2.circle(mask, drawn.mm(0, 0), drawn.px(10), 255, -1)
    (blob,) = outline_of_mask(mask, 0, 0, frame=(cam.width, cam.height))
    plane = TablePlane(cam, 0.08)
    assert plane.area_mm2(blob) == pytest.approx(math.pi * (drawn.px(10) / drawn.PX_PER_MM) ** 2, rel=0.05)
