"""The true camera model agrees with what the renderer draws."""

from __future__ import annotations

import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from cell.catalogue import KINDS
from cell.sim import layout


def _centroids(seg: np.ndarray) -> dict[int, np.ndarray]:
    out = {}
    for pid in np.unique(seg):
        if pid == 0:
            continue
        v, u = np.nonzero(seg == pid)
        out[int(pid)] = np.array([u.mean(), v.mean()])
    return out


def test_true_model_projects_part_centres_onto_segmentation_centroids(world_factory):
    world = world_factory(parts={"count": 6, "kinds": ["washer"]}, sensor={"noise_std": 0.0})
    spots = [(-0.05, 0.42), (0.0, 0.45), (0.05, 0.48), (-0.03, 0.49), (0.04, 0.41), (0.07, 0.45)]
    for x, y in spots:
        world.place_next_part(x, y, 0.0)
    world.step(100)
    frame = world.render()
    found = _centroids(frame.seg)
    assert set(found) == {p.id for p in world.parts}
    top = KINDS["washer"].height / 2
    for part in world.parts:
        pos, _ = world.part_pose(part.id)
        uv = frame.camera.project(pos + [0, 0, top])[0]
        assert np.linalg.norm(uv - found[part.id]) < 0.5, (part.id, uv, found[part.id])


def test_camera_model_matches_layout_and_opencv_axes(world_factory):
    world = world_factory()
    cam = world.camera_model("overhead")
    # Looking straight down: optical axis (camera +z) is world -z, image x is world +x.
    R = cam.T_world_camera[:3, :3]
    assert np.allclose(R[:, 2], [0, 0, -1]) and np.allclose(R[:, 0], [1, 0, 0])
    expected = layout.PICK_ZONE + [0, 0, layout.OVERHEAD_CAMERA_HEIGHT]
    assert np.allclose(cam.T_world_camera[:3, 3], expected)
    assert np.allclose(cam.project(layout.PICK_ZONE)[0], [(cam.width - 1) / 2, (cam.height - 1) / 2])


def test_depth_is_distance_along_optical_axis(world_factory):
    world = world_factory()
    frame = world.render()
    h, w = frame.depth.shape
    belt = frame.depth[h // 2, w // 2]
    assert abs(belt - layout.OVERHEAD_CAMERA_HEIGHT) < 1e-3
    assert frame.depth.dtype == np.float32 and frame.seg.dtype == np.int32


def test_sensor_distortion_moves_points_as_the_model_says(world_factory):
    dist = [-0.25, 0.08, 0.0, 0.0, 0.0]
    world = world_factory(parts={"count": 4, "kinds": ["washer"]},
                          sensor={"noise_std": 0.0, "distortion": dist})
    for x, y in [(-0.09, 0.38), (0.1, 0.52), (0.0, 0.45), (0.11, 0.39)]:
        world.place_next_part(x, y, 0.0)
    world.step(100)
    frame = world.render()
    assert np.allclose(frame.camera.dist, dist)
    found = _centroids(frame.seg)
    top = KINDS["washer"].height / 2
    for part in world.parts:
        pos, _ = world.part_pose(part.id)
        distorted = frame.camera.project(pos + [0, 0, top])[0]
        ideal = frame.camera.project(pos + [0, 0, top], distort=False)[0]
        assert np.linalg.norm(distorted - found[part.id]) < 1.0
        if np.linalg.norm(ideal - [319.5, 239.5]) > 150:  # far from centre: visibly moved
            assert np.linalg.norm(ideal - found[part.id]) > 3.0


def test_a_barrel_lens_sees_the_corners_where_its_model_says(world_factory):
    """The ideal render of a distorting lens reaches beyond the image (its field of view
    widened, its focal length kept): a disc the model puts at pixel (12, 12) is rendered
    where camera.json projects it."""
    import cv2

    dist = [-0.2, 0.05, 0.0, 0.0, 0.0]
    world = world_factory(parts={"count": 1, "kinds": ["disc"]},
                          sensor={"noise_std": 0.0, "distortion": dist})
    cam = world.camera_model()
    n = cv2.undistortPointsIter(np.array([[[12.0, 12.0]]]), cam.K, np.array(dist), None, None,
                                (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)).ravel()
    ray = cam.T_world_camera[:3, :3] @ [n[0], n[1], 1.0]
    centre = cam.T_world_camera[:3, 3]
    spot = centre + (KINDS["disc"].height - centre[2]) / ray[2] * ray  # (on the table)
    world.place_next_part(float(spot[0]), float(spot[1]), 0.0)
    world.step(50)
    pos, _ = world.part_pose(1)
    turn = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    radius = KINDS["disc"].length / 2
    rim = pos + np.stack([radius * np.cos(turn), radius * np.sin(turn),
                          np.full(400, KINDS["disc"].height / 2)], axis=1)  # the top's edge
    model = np.zeros((480, 640), np.uint8)
    cv2.fillPoly(model, [np.round(cam.project(rim)).astype(np.int32)], 1)
    seen = world.render().seg == 1
    iou = np.count_nonzero(seen & (model > 0)) / np.count_nonzero(seen | (model > 0))
    assert iou > 0.9, iou  # (its side, seen at the corner, is no part of the top's rim)


def test_a_lens_model_that_folds_the_image_is_refused(world_factory):
    """k1 = -0.3 at a 60-degree field of view turns back before the corners: 20 % of the
    pixels were rendered up to 350 px from where camera.json put what they showed."""
    from cell.errors import SimError

    world = world_factory(parts={"count": 1}, camera={"fovy": 60.0},
                          sensor={"distortion": [-0.3, 0.0, 0.0, 0.0, 0.0]})
    with pytest.raises(SimError, match=r"sensor.distortion \[-0.3, 0.0, 0.0, 0.0, 0.0\]: the lens "
                       r"model folds the image .*narrower camera.fovy"):
        world.render()


def test_segmentation_maps_mujocos_raw_ids_to_part_ids(world_factory):
    world = world_factory(parts={"count": 3, "kinds": ["washer"]}, sensor={"noise_std": 0.0})
    for x, y in [(-0.05, 0.42), (0.0, 0.45), (0.05, 0.48)]:
        world.place_next_part(x, y, 0.0)
    world.step(100)
    rig = world.rig("overhead")
    raw = rig.render_seg_raw(world.data)
    assert raw.dtype == np.int32 and raw.shape == (rig.sensor.height, rig.sensor.width, 2)
    assert np.array_equal(raw[..., 0] == -1, raw[..., 1] == -1)  # background is (-1, -1)
    obj, kind = raw[..., 0], raw[..., 1]
    is_geom = kind == int(mujoco.mjtObj.mjOBJ_GEOM)
    expected = np.where(is_geom, rig.part_of_geom[np.clip(obj, 0, None)], 0)
    assert np.array_equal(rig.part_ids(raw), expected)
    assert set(np.unique(rig.render_seg(world.data))) == {0} | {p.id for p in world.parts}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="headless GL as on Linux")
def test_mujoco_imported_before_cell_is_a_sim_error_that_says_what_to_do():
    # (a bare mujoco.FatalError: MuJoCo picks its GL backend on import, before cell sets
    # MUJOCO_GL=egl; notebooks often import mujoco, or mink, first)
    code = ("import mujoco, cell\n"
            "from cell.scenario import scenario_from_dict\nfrom cell.sim.world import World\n"
            "from cell.errors import SimError\n"
            "w = World.build(scenario_from_dict({}), arm=False)\n"
            "try:\n    w.render()\nexcept SimError as e:\n    print(e)\n")
    env = {k: v for k, v in os.environ.items()
           if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         timeout=120)
    assert "set MUJOCO_GL=egl in the environment, or import cell before mujoco" in out.stdout, out
