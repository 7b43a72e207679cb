import cv2
import numpy as np
import pytest

from cell.camera import CameraModel
from cell.errors import VisionError
from cell.vision.geometry import (
    apply_homography,
    birdseye_view,
    homography_from_points,
    pixel_to_table,
    solve_planar_pnp,
    table_homography,
)


def _overhead(dist=(-0.12, 0.05, 0.001, -0.0008, 0.0), tilt_deg=6.0):
    """A camera 0.40 m above a belt at z = 0.08, tilted a little, with lens distortion."""
    f = 0.5 * 480 / np.tan(np.radians(40) / 2)
    K = np.array([[f, 0, 319.5], [0, f, 239.5], [0, 0, 1]])
    a = np.radians(tilt_deg)
    R_flip = np.diag([1.0, -1.0, -1.0])  # camera z down onto the table, image y along -y
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    T = np.eye(4)
    T[:3, :3] = R_flip @ Rx
    T[:3, 3] = [0.0, 0.45, 0.48]
    return CameraModel(640, 480, K, np.array(dist), T)


def test_homography_from_four_points_recovers_a_known_one():
    H_true = np.array([[1.2, 0.1, 30.0], [-0.05, 0.9, 12.0], [1e-4, -2e-4, 1.0]])
    src = np.array([[0, 0], [100, 0], [100, 80], [0, 80]], float)
    H = homography_from_points(src, apply_homography(H_true, src))
    np.testing.assert_allclose(H, H_true, rtol=1e-5, atol=1e-7)
    probe = np.array([[37.0, 51.0], [-20.0, 130.0]])
    np.testing.assert_allclose(apply_homography(H, probe), apply_homography(H_true, probe),
                               atol=1e-3)


def test_homography_rejects_collinear_points():
    with pytest.raises(VisionError, match="src.*collinear"):
        homography_from_points([[0, 0], [1, 1], [2, 2], [0, 5]], [[0, 0], [1, 0], [1, 1], [0, 1]])
    with pytest.raises(VisionError, match="dst"):
        homography_from_points(np.zeros((4, 2)) + np.eye(4, 2), np.zeros((3, 2)))


def test_pixel_to_table_round_trip_through_project_is_sub_mm():
    cam = _overhead()
    rng = np.random.default_rng(40)
    P = np.c_[rng.uniform(-0.12, 0.12, 200), 0.45 + rng.uniform(-0.08, 0.08, 200),
              np.full(200, 0.08)]
    px = cam.project(P)
    assert np.all((px > 0) & (px < [640, 480]))
    back = pixel_to_table(cam, px, z=0.08)
    err = np.linalg.norm(back - P, axis=1)
    assert err.max() < 1e-6  # metres: far below a millimetre
    # ignoring the distortion would cost millimetres at the image edge
    naive = CameraModel(640, 480, cam.K, np.zeros(5), cam.T_world_camera)
    assert np.linalg.norm(pixel_to_table(naive, px, z=0.08) - P, axis=1).max() > 1e-3


def test_pixel_to_table_with_the_simulators_camera():
    from cell import sim
    from cell.scenario import scenario_from_dict

    world = sim.World.build(scenario_from_dict({"seed": 1}), arm=False)
    cam = world.camera_model("overhead")
    P = np.array([[0.0, 0.45, 0.08], [0.05, 0.40, 0.08], [-0.07, 0.50, 0.08]])
    np.testing.assert_allclose(pixel_to_table(cam, cam.project(P), z=0.08), P, atol=1e-7)


def test_table_homography_agrees_with_projection_without_distortion():
    cam = _overhead(dist=(0, 0, 0, 0, 0))
    P = np.array([[0.01, 0.42], [-0.05, 0.47], [0.09, 0.5]])
    H = table_homography(cam, z=0.08)
    np.testing.assert_allclose(apply_homography(H, P), cam.project(np.c_[P, [0.08] * 3]),
                               atol=1e-8)


def test_birdseye_view_straightens_a_checkerboard_on_the_table():
    cam = _overhead()
    sq = 0.01  # 10 mm squares on the belt plane z = 0.08

    def pattern(xy):
        return (((np.floor(xy[:, 0] / sq) + np.floor(xy[:, 1] / sq)) % 2) * 200 + 30)

    # the camera's image of the board: every pixel's ray meets the plane
    v, u = np.mgrid[0:480, 0:640]
    world = pixel_to_table(cam, np.c_[u.ravel(), v.ravel()].astype(float), z=0.08)
    image = pattern(world).reshape(480, 640).astype(np.uint8)
    res = 0.0005
    top = birdseye_view(image, cam, x_range=(-0.06, 0.06), y_range=(0.40, 0.50), resolution=res,
                        z=0.08)
    assert top.shape == (200, 240)
    j, i = np.meshgrid(np.arange(240), np.arange(200))
    xy = np.c_[-0.06 + (j.ravel() + 0.5) * res, 0.50 - (i.ravel() + 0.5) * res]
    expected = pattern(xy)
    agree = np.abs(top.astype(int).ravel() - expected) < 50
    frac = (xy / sq) % 1.0
    inner = np.all((frac > 0.15) & (frac < 0.85), axis=1)  # >= 1.5 mm from a square edge
    assert agree[inner].all()  # every square lands where the map says
    assert agree.mean() > 0.9  # the rest differ only in the blur across edges


def test_planar_pnp_recovers_the_target_pose():
    cam = _overhead()
    gx, gy = np.meshgrid(np.arange(8), np.arange(5))
    obj = np.c_[gx.ravel(), gy.ravel()] * 0.025
    rvec = np.array([0.2, -0.15, 0.6])
    tvec = np.array([-0.05, 0.02, 0.45])
    img, _ = cv2.projectPoints(np.c_[obj, np.zeros(len(obj))], rvec, tvec, cam.K, cam.dist)
    img = img.reshape(-1, 2) + np.random.default_rng(41).normal(0, 0.1, (len(obj), 2))
    pose = solve_planar_pnp(obj, img, cam.K, cam.dist)
    R_true = cv2.Rodrigues(rvec)[0]
    dR = pose.T_camera_target[:3, :3] @ R_true.T
    angle = np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)))
    assert angle < 0.2
    assert np.linalg.norm(pose.T_camera_target[:3, 3] - tvec) < 1e-3
    assert pose.rms_px < 0.2


def test_geometry_errors_name_the_argument():
    cam = _overhead()
    with pytest.raises(VisionError, match="pixels"):
        pixel_to_table(cam, np.zeros((3, 3)))
    with pytest.raises(VisionError, match="camera"):
        pixel_to_table("cam", np.zeros((1, 2)))
    up = CameraModel(640, 480, cam.K, np.zeros(5), np.eye(4))  # looks sideways: z forward = +z
    with pytest.raises(VisionError, match="does not see the plane"):
        pixel_to_table(up, [[319.5, 239.5]], z=-1.0)
    with pytest.raises(VisionError, match="resolution"):
        birdseye_view(np.zeros((480, 640), np.uint8), cam, x_range=(0, 1), y_range=(0, 1),
                      resolution=0)


_SQ = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)


@pytest.mark.parametrize("k_src, k_dst", [(1e200, 1.0), (1.0, 1e39), (1e-30, 1.0), (1e-14, 1.0)])
def test_homography_from_points_is_exact_far_beyond_float32(k_src, k_dst):
    """A pure scaling between squares of any size: no NaN (float32 overflow), no
    'collinear' for a tiny square."""
    H = homography_from_points(_SQ * k_src, _SQ * k_dst)
    np.testing.assert_allclose(H, np.diag([k_dst / k_src, k_dst / k_src, 1.0]), rtol=1e-6)


def test_homography_from_points_refuses_an_overflowing_homography():
    with pytest.raises(VisionError, match="'src', 'dst'.*overflows"):
        homography_from_points(_SQ * 1e-300, _SQ * 1e300)


@pytest.mark.parametrize("scale", [1e-30, 1e-16, 1e20, 1e39])
def test_apply_homography_applies_what_homography_from_points_gives(scale):
    """Point sets of scales 30 decades apart, as homography_from_points allows: H is
    diag(s, s, 1)-like, invertible (its rank test called it singular from 1e15 on)."""
    dst = _SQ * scale + scale
    out = apply_homography(homography_from_points(_SQ, dst), _SQ)
    np.testing.assert_allclose(out, dst, rtol=1e-6)


@pytest.mark.parametrize("H, culprit", [
    (np.full((3, 3), np.nan), "argument 'H': holds NaN"),
    (np.zeros((3, 3)), "argument 'H': singular"),
    (np.array([[1, 2, 3], [2, 4, 6], [0, 0, 1.0]]), "argument 'H': singular"),
    ("abc", "argument 'H': expected a"),
    (np.array([[1, 0, 0], [0, 1, 0], [1, 0, 1.0]]), "argument 'points': point \\[-1.0, 5.0\\]"),
])
def test_apply_homography_refuses_what_gives_no_finite_point(H, culprit):
    with pytest.raises(VisionError, match=culprit):
        apply_homography(H, [[-1, 5]])


@pytest.mark.parametrize("z, culprit", [
    (np.nan, "argument 'z': nan is outside"),
    (np.inf, "argument 'z': inf is outside"),
    ("0", "argument 'z': expected a number"),
    (0.48, "argument 'z': the plane z = 0.48 must lie below the camera"),
    (1.0, "argument 'z'"),
])
def test_plane_height_is_checked(z, culprit):
    cam = _overhead()
    with pytest.raises(VisionError, match=culprit):
        table_homography(cam, z=z)
    with pytest.raises(VisionError, match=culprit):
        pixel_to_table(cam, [[320, 240]], z=z)
    with pytest.raises(VisionError, match=culprit):
        birdseye_view(np.zeros((480, 640), np.uint8), cam, x_range=(-0.05, 0.05),
                      y_range=(0.4, 0.5), resolution=0.002, z=z)


def test_pixel_to_table_of_no_pixels_is_no_points():
    assert pixel_to_table(_overhead(), np.zeros((0, 2))).shape == (0, 3)


@pytest.mark.parametrize("kwargs, culprit", [
    ({"resolution": 1e-9}, "argument 'resolution': .* 4194304 pixels"),  # 71 PiB of grid
    ({"resolution": 1.0}, "argument 'resolution': .* 0 x 0 pixel view"),
    ({"resolution": np.inf}, "argument 'resolution'"),
    ({"resolution": np.nan}, "argument 'resolution'"),
    ({"resolution": "0.002"}, "argument 'resolution'"),
    ({"x_range": (np.nan, 0.05)}, "argument 'x_range'"),
    ({"x_range": (-np.inf, 0.05)}, "argument 'x_range'"),
    ({"x_range": 0.05}, "argument 'x_range': expected \\(min, max\\)"),
    ({"x_range": (0, 1, 2)}, "argument 'x_range': expected \\(min, max\\)"),
    ({"y_range": (0.5, 0.4)}, "argument 'y_range': expected \\(min, max\\) with min < max"),
    ({"image": np.zeros((100, 100), np.uint8)}, "argument 'image': 100 x 100 pixels"),
])
def test_birdseye_view_refuses_bad_extents(kwargs, culprit):
    call = {"image": np.zeros((480, 640), np.uint8), "x_range": (-0.05, 0.05),
            "y_range": (0.4, 0.5), "resolution": 0.002, **kwargs}
    image = call.pop("image")
    with pytest.raises(VisionError, match=culprit):
        birdseye_view(image, _overhead(), **call)


def _looking_down(tilt_deg=0.0, dist=(0.0, 0.0, 0.0, 0.0, 0.0), f=300.0):
    """A 640x480 camera 1 m above the plane z = 0, turned ``tilt_deg`` from straight down
    towards +y."""
    a = np.radians(tilt_deg)
    turn = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0]) @ turn
    T[:3, 3] = [0.0, 0.0, 1.0]
    K = np.array([[f, 0, 319.5], [0, f, 239.5], [0, 0, 1]])
    return CameraModel(640, 480, K, np.array(dist, float), T)


def test_birdseye_view_is_black_where_the_camera_cannot_see():
    """A plane point behind the camera (a camera tilted 80 degrees sees the horizon) and one
    past its lens model's fold (barrel k1 = -0.3 turns back at 1.054 focal lengths from
    the axis) are black: they showed a mirrored and a folded copy of the image."""
    bright = np.full((480, 640), 200, np.uint8)
    cam = _looking_down(tilt_deg=80.0)
    top = birdseye_view(bright, cam, x_range=(-2, 2), y_range=(-4, 4), resolution=0.02)
    ys = 4 - (np.arange(top.shape[0]) + 0.5) * 0.02
    behind = (np.c_[np.zeros_like(ys), ys, np.zeros_like(ys)] @ cam.T_camera_world[:3, :3].T
              + cam.T_camera_world[:3, 3])[:, 2] <= 0
    assert behind.sum() > 50 and not top[behind].any() and top[~behind].any()
    cam = _looking_down(dist=(-0.3, 0.0, 0.0, 0.0, 0.0))
    top = birdseye_view(bright, cam, x_range=(-3, 3), y_range=(-3, 3), resolution=0.01)
    xs = -3 + (np.arange(600) + 0.5) * 0.01
    X, Y = np.meshgrid(xs, xs[::-1])
    r = np.hypot(X, Y)  # the ray's distance from the axis, in focal lengths
    assert not top[r > 1.06].any()  # past the fold
    uv = cam.project(np.c_[X.ravel(), Y.ravel(), np.zeros(X.size)]).reshape(600, 600, 2)
    in_image = (uv >= 2).all(axis=2) & (uv[..., 0] <= 637) & (uv[..., 1] <= 477)
    assert (top[(r < 1.04) & in_image] == 200).all()  # before it, what the image shows


_OBJ = [[0, 0], [0.1, 0], [0.1, 0.1], [0, 0.1]]
_IMG = [[100, 100], [200, 100], [200, 200], [100, 200]]
_K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])


@pytest.mark.parametrize("args, culprit", [
    ((_OBJ, _IMG, np.full((3, 3), np.nan)), "argument 'K': holds NaN"),
    ((_OBJ, _IMG, np.zeros((3, 3))), "argument 'K': expected intrinsics"),
    ((_OBJ, _IMG, "K"), "argument 'K'"),
    ((_OBJ, _IMG, _K, [0.1, 0.2, 0.3]), "argument 'dist': expected 4, 5, 8, 12 or 14"),
    ((_OBJ, _IMG, _K, [np.nan] * 5), "argument 'dist': holds NaN"),
    ((_OBJ, _IMG, _K, "abcde"), "argument 'dist'"),
    (([[0, 0], [0.1, 0], [0.2, 0], [0.3, 0]], _IMG, _K), "argument 'object_points': .* one line"),
    (([[0, 0]] * 4, _IMG, _K), "argument 'object_points': .* one line"),
    (("abcd", _IMG, _K), "argument 'object_points'"),
    ((_OBJ, [[100, 100]] * 4, _K), "argument 'image_points': PnP found no"),
])
def test_solve_planar_pnp_refuses_what_gives_no_pose(args, culprit):
    with pytest.raises(VisionError, match=culprit):
        solve_planar_pnp(*args)


def test_a_pixel_past_the_lens_fold_has_no_ray_and_is_named():
    """Barrel k1 = -1.5 turns back before the image corner: that corner has no ray (it got
    a made-up point on the table); the middle of the image still has one."""
    cam = _overhead(dist=(-1.5, 0.0, 0.0, 0.0, 0.0))
    with pytest.raises(VisionError, match=r"pixel_to_table: pixel \(0, 0\) has no ray"):
        pixel_to_table(cam, np.array([[320.0, 240.0], [0.0, 0.0]]), z=0.08)
    assert np.isfinite(pixel_to_table(cam, np.array([[320.0, 240.0]]), z=0.08)).all()
