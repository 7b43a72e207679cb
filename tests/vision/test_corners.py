import cv2
import numpy as np
import pytest

from cell.errors import VisionError
from cell.vision.corners import harris_corners, harris_response, non_max_suppression
from tests.vision import box_scene


@pytest.mark.parametrize(("block_size", "ksize", "k"), [(2, 3, 0.04), (3, 3, 0.04), (5, 5, 0.06)])
def test_response_equals_opencv_corner_harris(block_size, ksize, k):
    img, *_ = box_scene.render(box_scene.camera(), seed=1)
    ours = harris_response(img, block_size=block_size, ksize=ksize, k=k)
    ref = cv2.cornerHarris(img, block_size, ksize, k)
    np.testing.assert_allclose(ours, ref, atol=1e-6 * np.abs(ref).max())
    f = img.astype(np.float32)
    np.testing.assert_allclose(harris_response(f, block_size=3), cv2.cornerHarris(f, 3, 3, 0.04),
                               rtol=1e-4, atol=1e-3)


def test_response_sign_corner_edge_flat():
    img = np.zeros((40, 40), np.uint8)
    img[20:, 20:] = 200
    r = harris_response(img, block_size=3)
    assert r[20, 20] > 0  # corner
    assert r[30, 20] < 0  # edge
    assert r[5, 5] == 0  # flat


def test_nms_keeps_one_point_per_peak():
    r = np.zeros((30, 30), np.float32)
    r[10, 10], r[10, 12], r[20, 20] = 5.0, 4.0, 3.0
    r[25, 5:7] = 2.0  # a plateau of two equal pixels
    pts = non_max_suppression(r, min_distance=3, threshold=1.0)
    assert pts.tolist() == [[10.0, 10.0], [20.0, 20.0], [5.5, 25.0]]


@pytest.mark.parametrize(("yaw_deg", "seed"), [(5, 0), (10, 1), (10, 2), (15, 3)])
def test_harris_finds_each_visible_vertex_of_a_box(yaw_deg, seed):
    cam = box_scene.camera()
    img, *_ = box_scene.render(cam, yaw=np.radians(yaw_deg), seed=seed)
    truth = box_scene.corner_vertices(cam, yaw=np.radians(yaw_deg))
    assert len(truth) == 7  # top face + two side faces: 7 visible vertices
    pts = harris_corners(img, block_size=5, threshold_rel=0.003, min_distance=4)
    d = np.hypot(*(pts[:, None, :] - truth[None]).transpose(2, 0, 1))
    assert len(pts) == len(truth)  # one point per corner, nothing else
    assert d.min(axis=0).max() < 2.0  # every vertex found within 2 px
    assert sorted(d.argmin(axis=0).tolist()) == list(range(len(truth)))


def test_corner_errors_name_the_argument():
    with pytest.raises(VisionError, match="block_size"):
        harris_response(np.zeros((8, 8), np.uint8), block_size=1)
    with pytest.raises(VisionError, match="refine"):
        harris_corners(np.zeros((8, 8), np.uint8), refine="fast")


@pytest.mark.parametrize(
    ("finish", "yaw"),
    [("plastic_white", 0.4), ("plastic_grey", 1.9), ("plastic_white", 2.8), ("plastic_grey", 0.4)],
)
def test_harris_finds_each_vertex_of_a_rendered_l_bracket(finish, yaw):
    """Renders have no anti-aliasing: the staircase of a slanted edge gives weak
    responses, which a threshold of 10 % of the peak removes."""
    pytest.importorskip("cell.sim")
    frame, world, part = box_scene.render_part("l_bracket", finish, "front", yaw=yaw)
    truth = frame.camera.project(box_scene.bracket_outline_vertices(world, part))
    world.close()
    assert len(truth) == 6  # five convex corners and the inner one
    grey = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2GRAY)
    pts = harris_corners(grey, block_size=5, threshold_rel=0.1, min_distance=4)
    d = np.hypot(*(pts[:, None, :] - truth[None]).transpose(2, 0, 1))
    assert len(pts) == 6
    assert d.min(axis=0).max() < 2.0
    assert sorted(d.argmin(axis=0).tolist()) == list(range(6))
