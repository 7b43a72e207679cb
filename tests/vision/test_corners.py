import math

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


def _quadratic_nms(response, min_distance, threshold):
    """The former non-maximum suppression, kept as the reference: the same dilation
    and plateau centroids, then every candidate against every kept one (O(n^2))."""
    size = 2 * min_distance + 1
    peak = cv2.dilate(response, np.ones((size, size), np.uint8))
    keep = (response >= peak) & (response > threshold)
    n, labels, _, cents = cv2.connectedComponentsWithStats(keep.view(np.uint8), connectivity=8)
    if n <= 1:
        return np.zeros((0, 2)), 0
    strength = np.zeros(n)
    np.maximum.at(strength, labels[keep], response[keep])
    chosen = []
    for p in cents[np.argsort(-strength[1:], kind="stable") + 1]:
        if all(math.hypot(*(p - q)) >= min_distance for q in chosen):  # as the code: same bits
            chosen.append(p)
    return np.array(chosen), n - 1


def _squares(rows, cols, *, cell=50, seed=0):
    """One axis-aligned square of random size and grey per cell on a dark ground;
    returns the image and the squares' vertices (x, y) at the pixel boundaries."""
    rng = np.random.default_rng(seed)
    img = np.full((rows * cell, cols * cell), 40, np.uint8)
    vertices = []
    for i in range(rows):
        for j in range(cols):
            s = int(rng.integers(cell // 3, cell * 2 // 3))
            y = i * cell + int(rng.integers(4, cell - s - 3))
            x = j * cell + int(rng.integers(4, cell - s - 3))
            img[y : y + s, x : x + s] = rng.integers(120, 250)
            vertices += [(x + dx - 0.5, y + dy - 0.5) for dx in (0, s) for dy in (0, s)]
    return img, np.array(vertices)


@pytest.mark.parametrize("min_distance", [1, 2, 3, 5])
def test_nms_equals_the_quadratic_method_on_plateaus_and_ties(min_distance):
    """Four levels: many equal, non-touching maxima within min_distance, so the greedy
    distance pass (not only the dilation) decides."""
    dropped = 0
    for seed in range(6):
        r = np.random.default_rng(seed).integers(0, 4, (60, 80)).astype(np.float32)
        ref, n_candidates = _quadratic_nms(r, min_distance, 0.5)
        dropped += n_candidates - len(ref)
        np.testing.assert_array_equal(
            non_max_suppression(r, min_distance=min_distance, threshold=0.5), ref)
    assert dropped > 0  # the distance pass was exercised


@pytest.mark.parametrize("min_distance", [1, 2, 4, 7])
@pytest.mark.parametrize("seed", range(3))
def test_nms_equals_the_quadratic_method_on_harris_responses(min_distance, seed):
    img, _ = _squares(3, 4, seed=seed)
    noisy = np.random.default_rng(seed).normal(0, 20, img.shape)
    for image in (img, np.clip(cv2.GaussianBlur(img + noisy, (0, 0), 1.0), 0, 255).astype(np.uint8)):
        r = harris_response(image, block_size=3)
        threshold = 0.001 * float(r.max())
        ref, _ = _quadratic_nms(r, min_distance, threshold)
        assert len(ref) >= 48
        np.testing.assert_array_equal(
            non_max_suppression(r, min_distance=min_distance, threshold=threshold), ref)
        if min_distance == 4:  # and so does harris_corners without refinement
            np.testing.assert_array_equal(
                harris_corners(image, block_size=3, threshold_rel=0.001, refine="none"), ref)


def test_harris_finds_each_of_1024_corners_of_a_large_image():
    img, truth = _squares(16, 16)
    pts = harris_corners(img, block_size=3, threshold_rel=0.02, min_distance=4)
    assert len(truth) == 1024
    assert len(pts) == len(truth)
    d = np.hypot(*(pts[:, None, :] - truth[None]).transpose(2, 0, 1))
    assert d.min(axis=0).max() < 1.0  # every vertex found, to sub-pixel accuracy
    assert len(set(d.argmin(axis=0).tolist())) == len(truth)  # by a point of its own


def test_harris_gives_each_checkerboard_corner_once():
    """A blurred X-junction has four response peaks 3 px apart; two survive the NMS and
    refine onto one apex: the stronger is kept, so each inner corner of an axis-aligned
    board comes once and the points stay min_distance apart."""
    square = 20
    board = (((np.indices((240, 320)) // square).sum(0) % 2) * 160 + 40).astype(np.uint8)
    pts = harris_corners(cv2.GaussianBlur(board, (0, 0), 1.0), min_distance=4)
    inner = np.array([(x * square - 0.5, y * square - 0.5)
                      for x in range(1, 16) for y in range(1, 12)])
    assert len(pts) == len(inner) == 165
    d = np.hypot(*(pts[:, None] - inner[None]).transpose(2, 0, 1))
    assert d.min(axis=0).max() < 0.5 and len(set(d.argmin(axis=0).tolist())) == 165
    gaps = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1)) + 1e9 * np.eye(len(pts))
    assert gaps.min() >= 4


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


@pytest.mark.parametrize(("name", "value"), [
    ("min_distance", np.nan), ("min_distance", np.inf), ("min_distance", "3"),
    ("min_distance", 2**31), ("min_distance", 0), ("min_distance", 2.5),
    ("threshold", "0"), ("threshold", np.nan), ("threshold", np.inf),
])
def test_nms_refuses_bad_numbers(name, value):
    r = np.zeros((20, 20), np.float32)
    kw = {"min_distance": 3, "threshold": 0.0, name: value}
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        non_max_suppression(r, **kw)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nms_and_response_refuse_non_finite_pixels(bad):
    a = np.random.default_rng(0).random((40, 40)).astype(np.float32)
    a[30, 30] = bad
    with pytest.raises(VisionError, match="argument 'response'"):
        non_max_suppression(a, min_distance=3, threshold=0.0)
    with pytest.raises(VisionError, match="argument 'image'"):
        harris_response(a)


def test_nms_window_wider_than_the_image_keeps_the_global_maximum():
    r = np.random.default_rng(1).random((30, 40)).astype(np.float32)
    pts = non_max_suppression(r, min_distance=10**9, threshold=0.0)  # allocated exabytes
    y, x = np.unravel_index(r.argmax(), r.shape)
    np.testing.assert_array_equal(pts, [[x, y]])


@pytest.mark.parametrize(("name", "value"), [
    ("k", np.nan), ("k", np.inf), ("k", "0.04"), ("k", 1e18), ("k", -0.1),
    ("block_size", 2**31 + 1), ("block_size", 3.0), ("block_size", "3"),
])
def test_response_refuses_bad_numbers(name, value):
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        harris_response(np.zeros((20, 20), np.uint8), **{name: value})


@pytest.mark.parametrize(("name", "value"), [
    ("threshold_rel", "0.1"), ("threshold_rel", np.nan), ("threshold_rel", 1.0),
    ("block_size", "3"), ("block_size", 4), ("block_size", 1), ("smooth", np.nan),
    ("smooth", -1), ("smooth", np.inf), ("smooth", 1e18), ("smooth", "1"), ("k", np.nan),
    ("min_distance", np.nan), ("min_distance", -1),
])
@pytest.mark.parametrize("flat", [False, True])
def test_harris_corners_refuses_bad_arguments(name, value, flat):
    img = np.zeros((20, 20), np.uint8)
    if not flat:
        img[5:, 5:] = 255
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        harris_corners(img, **{name: value})


@pytest.mark.parametrize("size", [6, 7, 10, 12])
def test_harris_corners_on_a_tiny_image(size):
    a = np.zeros((size, size), np.uint8)
    a[3:, 3:] = 255
    pts = harris_corners(a, min_distance=4)
    assert len(pts) >= 1 and np.all(np.hypot(pts[:, 0] - 2.5, pts[:, 1] - 2.5) < 2.0)


def test_nms_threshold_is_strict():
    """Only values above the threshold are kept: a zero background with threshold 0
    yields the single peak, not also a plateau centroid of the flat zeros."""
    r = np.zeros((30, 30), np.float32)
    r[10, 12] = 5.0
    pts = non_max_suppression(r, min_distance=3, threshold=0.0)
    np.testing.assert_allclose(pts, [[12.0, 10.0]])
    assert len(non_max_suppression(r, min_distance=3, threshold=5.0)) == 0
