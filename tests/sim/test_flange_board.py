"""The flange board (eye-to-hand calibration target), World.hold_arm, and the poses that
show the board to the overhead camera."""

from __future__ import annotations

import math

import cv2
import mujoco
import numpy as np
import pytest

from cell.errors import IKError, SimError
from cell.robot.ik import ArmIK
from cell.scenario import scenario_from_dict
from cell.sim import flange_board
from cell.sim.arm import HOME, build_arm
from cell.sim.board_poses import READY, BoardPoseSampler, propose_flange_board_poses
from cell.sim.world import World

POSE_SEED = 11  # the tests' pose draw (the benchmarks use others)
N_POSES = 16
_SUBPIX = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)


def _scenario(**sections):
    return scenario_from_dict({"seed": 4, "parts": {"count": 1}, **sections})


@pytest.fixture(scope="module")
def board_world():
    w = World.build(_scenario(), arm=True, flange_board=True, msaa=4)
    yield w
    w.close()


@pytest.fixture(scope="module")
def poses():
    return propose_flange_board_poses(N_POSES, seed=POSE_SEED)


def _detect(rgb: np.ndarray) -> np.ndarray | None:
    grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    found, corners = cv2.findChessboardCorners(grey, flange_board.INNER_CORNERS)
    if not found:
        return None
    return cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1), _SUBPIX)[:, 0]


def _truth_px(world: World) -> np.ndarray:
    return world.camera_model("overhead").project(world.flange_board_corners_world())


def _board_pose(world: World) -> np.ndarray:
    return world.flange_pose() @ flange_board.T_flange_board()


# --- the option changes nothing when off ------------------------------------------------
def test_the_arm_without_the_board_is_exactly_the_arm_with_the_board_taken_off():
    plain = build_arm().to_xml()
    assert build_arm(flange_board=False).to_xml() == plain
    spec = build_arm(flange_board=True)
    assert spec.to_xml() != plain
    spec.delete(spec.body(flange_board.BODY))
    for name in ("flange_board_white", "flange_board_black"):
        spec.delete(spec.material(name))
    assert spec.to_xml() == plain


def test_a_default_world_has_no_board_and_renders_as_with_the_options_off():
    a = World.build(_scenario())
    b = World.build(_scenario(), flange_board=False, msaa=0)
    try:
        assert a.spec.to_xml() == b.spec.to_xml()
        assert "flange_board" not in a.spec.to_xml()
        assert a.model.vis.quality.offsamples == 0
        assert not a.has_flange_board
        np.testing.assert_array_equal(a.render("overhead").rgb, b.render("overhead").rgb)
        with pytest.raises(SimError, match="flange_board=True"):
            a.flange_board_corners_world()
    finally:
        a.close()
        b.close()


def test_options_are_checked():
    with pytest.raises(SimError, match="needs the arm"):
        World.build(_scenario(), arm=False, flange_board=True)
    for bad in (-1, 17, 2.5, True, "4"):
        with pytest.raises(SimError, match="msaa"):
            World.build(_scenario(), arm=False, msaa=bad)


# --- geometry, mass -----------------------------------------------------------------------
def test_ground_truth_geometry_is_the_models():
    T = flange_board.T_flange_board()
    R = T[:3, :3]
    assert np.allclose(R.T @ R, np.eye(3)) and np.isclose(np.linalg.det(R), 1.0)
    nx, ny = flange_board.INNER_CORNERS
    s = flange_board.SQUARE
    pts = flange_board.board_corners()
    assert pts.shape == (nx * ny, 3) and np.all(pts[:, 2] == 0)
    assert np.allclose(np.diff(pts[:nx, 0]), s) and np.allclose(pts[::nx, 1][1:] - pts[::nx, 1][:-1], s)
    assert np.allclose(pts.mean(axis=0), 0)
    assert np.allclose(flange_board.corners_in_flange(), pts @ R.T + T[:3, 3])
    # board x along the flange's +y, y along the tool axis, z into the board (flange +x)
    assert np.allclose(R, [[0, 0, 1], [1, 0, 0], [0, 1, 0]])

    # From the compiled model: each inner corner is where two black squares meet corner to
    # corner, on their mid-height plane.
    m = build_arm(flange_board=True).compile()
    d = mujoco.MjData(m)
    d.qpos[:] = READY
    mujoco.mj_kinematics(m, d)
    Tf = np.eye(4)
    Tf[:3, :3], Tf[:3, 3] = d.site("flange").xmat.reshape(3, 3), d.site("flange").xpos
    corners = flange_board.corners_in_flange() @ Tf[:3, :3].T + Tf[:3, 3]
    squares = [g for g in range(m.ngeom) if m.geom(g).name.startswith("flange_board_sq_")]
    assert len(squares) == ((nx + 1) * (ny + 1) + 1) // 2
    centres = d.geom_xpos[squares]
    for c in corners:
        dist = np.linalg.norm(centres - c, axis=1)
        assert np.sum(np.isclose(dist, s / math.sqrt(2), atol=1e-9)) == 2


def test_the_plate_is_a_light_gravity_compensated_body_that_collides_with_the_cell():
    m = build_arm(flange_board=True).compile()
    body = m.body(flange_board.BODY)
    assert body.mass[0] == pytest.approx(flange_board.MASS) and flange_board.MASS < 0.15
    assert m.body_gravcomp[body.id] == 1.0
    assert m.body(body.parentid[0]).name == "tool"  # not the tool body: no adhesion on it
    plate = m.geom(flange_board.PLATE_GEOM)
    assert (plate.contype[0], plate.conaffinity[0]) == (2, 1)  # like the arm's links
    assert all(m.geom(g).contype[0] == 0 for g in range(m.ngeom)
               if m.geom(g).name.startswith("flange_board_sq_"))
    assert m.nu == build_arm().compile().nu  # same actuators, suction included
    # matte: no highlight on a tilted board
    assert m.mat("flange_board_white").specular[0] == 0.0


# --- hold_arm -----------------------------------------------------------------------------
def test_hold_arm_places_the_arm_and_keeps_it_still(board_world):
    w = board_world
    w.hold_arm(READY)
    np.testing.assert_allclose(w.arm_joint_positions(), READY)
    w.step(500)
    assert np.abs(w.arm_joint_positions() - READY).max() < 1e-6
    T = _board_pose(w)  # READY: the board flat 0.25 m under the camera, face up
    assert np.allclose(T[:3, 3], [0.0, 0.45, 0.23], atol=1e-4)
    assert T[:3, 2] @ [0, 0, -1] > math.cos(math.radians(0.01))
    w.hold_arm(HOME)


def test_hold_arm_rejects_bad_joint_angles(board_world):
    for bad in ([0.0] * 5, [np.nan] * 6, [0, 0, 4.0, 0, 0, 0]):
        with pytest.raises(SimError, match="hold_arm"):
            board_world.hold_arm(np.array(bad))
    w = World.build(_scenario(), arm=False)
    try:
        with pytest.raises(SimError, match="no arm"):
            w.hold_arm(HOME)
    finally:
        w.close()


# --- detection ----------------------------------------------------------------------------
def test_board_is_detected_at_ready_where_the_truth_projects(board_world):
    w = board_world
    w.hold_arm(READY)
    found = _detect(w.render("overhead", depth=False, seg=False).rgb)
    assert found is not None
    err = np.linalg.norm(found - _truth_px(w), axis=1)
    assert err.max() < 0.5, err.max()


def test_board_is_detected_in_every_proposed_pose_within_half_a_pixel(board_world, poses):
    w = board_world
    errors = []
    for q in poses:
        w.hold_arm(q)
        found = _detect(w.render("overhead", depth=False, seg=False).rgb)
        assert found is not None
        errors.append(np.linalg.norm(found - _truth_px(w), axis=1))  # same corner order
    e = np.concatenate(errors)
    assert e.max() < 0.5, e.max()
    assert np.sqrt(np.mean(e**2)) < 0.15


# --- the poses ----------------------------------------------------------------------------
def test_poses_are_reproducible_and_many():
    a = propose_flange_board_poses(15, seed=POSE_SEED)
    b = propose_flange_board_poses(15, seed=POSE_SEED)
    assert a.shape == (15, 6)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, propose_flange_board_poses(15, seed=POSE_SEED + 1))


def test_poses_are_collision_free_on_the_way_and_in_the_world(board_world, poses):
    ik = ArmIK()
    sampler = BoardPoseSampler(ik=ik)
    w = board_world
    arm_geoms = {g for g in range(w.model.ngeom)
                 if w.model.geom(g).name.startswith("arm/")}
    prev = HOME
    for q in [READY, *poses]:
        assert ik.collides(q, clearance=0.01) is None
        assert sampler.collides(q) is None
        w.hold_arm(q)  # the world's own contact detection: nothing touches the arm
        d = w.data
        touching = [c for c in d.contact[: d.ncon] if {c.geom1, c.geom2} & arm_geoms]
        assert not touching
    for q in poses:
        assert sampler.path_collides(prev, q) is None
        assert sampler.path_collides(HOME, q) is None
        prev = q
    w.hold_arm(HOME)


def test_poses_tilt_the_board_about_many_axes(board_world, poses):
    w = board_world
    R = []
    for q in poses:
        w.hold_arm(q)
        R.append(_board_pose(w)[:3, :3])
    tilts = [math.degrees(math.acos(-Rk[2, 2])) for Rk in R]  # board z points down, into it
    assert min(tilts) < 20 and max(tilts) > 35 and max(tilts) <= 46.5  # drawn in 12..45
    axes, angles = [], []
    for i in range(len(R)):
        for j in range(i + 1, len(R)):
            Rij = R[i].T @ R[j]
            angles.append(math.degrees(math.acos(np.clip((np.trace(Rij) - 1) / 2, -1, 1))))
            ax = np.array([Rij[2, 1] - Rij[1, 2], Rij[0, 2] - Rij[2, 0], Rij[1, 0] - Rij[0, 1]])
            axes.append(ax / np.linalg.norm(ax))
    A = np.array(axes)
    spread = np.linalg.eigvalsh(A.T @ A / len(A))  # 1/3 each for axes in every direction
    assert spread.min() > 0.15, spread
    assert np.median(angles) > 20
    w.hold_arm(HOME)


def test_proposer_reports_when_it_cannot_find_enough_poses():
    with pytest.raises(IKError, match="rejected"):
        propose_flange_board_poses(3, seed=0, tilt=(80.0, 85.0), max_view_angle=30.0)


def test_the_wrist_camera_sees_the_same_with_and_without_the_plate():
    a = World.build(_scenario(), arm=True, flange_board=True)
    b = World.build(_scenario(), arm=True)
    try:
        for q in (HOME, READY):
            a.hold_arm(q)
            b.hold_arm(q)
            # the ideal renders: nowhere the plate. The plate changes the model's extent,
            # hence the depth range, by a hair: a grey level here and there (one on this
            # renderer), and another GL may resolve an edge pixel's depth test otherwise;
            # the plate in view would change thousands of pixels (over 1 % of the frame)
            x = a.rig("wrist").render_rgb(a.data).astype(int)
            y = b.rig("wrist").render_rgb(b.data).astype(int)
            changed = np.abs(x - y).max(axis=2) > 2
            assert changed.mean() < 1e-3, f"{changed.sum()} pixels differ by more than 2 levels"
    finally:
        a.close()
        b.close()
