"""cell.replay: the rerun recording of a run, checked with rerun's own reader and CLI."""

from __future__ import annotations

import gc
import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from cell.errors import CellError
from cell.replay import Replay, _box_size, _boxes, recording_id
from cell.vision import PartDetector


@pytest.fixture(scope="module")
def scene(module_world_factory):
    """A world with the arm and two parts, one part under the camera, a frame and its detections."""
    world = module_world_factory(arm=True, seed=1, parts={"count": 2})
    assert world.run_until_part_at_pick()
    frame = world.render("overhead")
    return world, frame, PartDetector().detect(frame.rgb, frame.camera)


@pytest.fixture
def strict():
    """rerun raises instead of logging a warning for bad data (its default is to warn)."""
    before = rr.strict_mode()
    rr.set_strict_mode(True)
    yield
    rr.set_strict_mode(before)


def _write(path, scene, captures: int = 3) -> None:
    world, frame, dets = scene
    with Replay(path, world) as rep:
        for i in range(captures):
            world.step(5)
            rep.log_state(world.time, world)
            rep.log_capture(world.time, rgb=frame.rgb, detections=dets, seg=frame.seg,
                            camera=frame.camera, preset="front")
            rep.log_metrics(world.time, {"picked": float(i), "rate": None, "error_mm": float("nan")})
        rep.log_event(world.time, "done", level="warning")


def _cli(*args: str) -> subprocess.CompletedProcess:
    """The rerun CLI of this environment (CI=1: no analytics notice, nothing sent)."""
    env = {**os.environ, "CI": "1"}
    return subprocess.run([sys.executable, "-m", "rerun_cli", *args], capture_output=True, text=True,
                          env=env, timeout=120)


def _entities(path) -> dict[str, set[str]]:
    """Entity path -> its component columns, from rerun's own reader."""
    out: dict[str, set[str]] = {}
    for chunk in RrdReader(path).stream():
        out.setdefault(chunk.entity_path, set()).update(chunk.to_record_batch().schema.names)
    return out


def test_replay_verifies_and_holds_what_was_logged(tmp_path, scene, strict):
    path = tmp_path / "r.rrd"
    _write(path, scene)
    verify = _cli("rrd", "verify", str(path))
    assert verify.returncode == 0, verify.stderr
    ents = _entities(path)
    assert "EncodedImage:blob" in ents["/world/overhead_camera/image"]
    assert "Pinhole:image_from_camera" in ents["/world/overhead_camera"]
    assert "Boxes2D:labels" in ents["/world/overhead_camera/detections"]
    assert "SegmentationImage:buffer" in ents["/truth/segmentation"]
    assert "AnnotationContext:context" in ents["/truth"]
    assert "Transform3D:quaternion" in ents["/world/bodies/part_1"]
    assert "Transform3D:translation" in ents[r"/world/bodies/arm\/wrist_3_link"]
    assert "Boxes3D:half_sizes" in ents["/world/bodies/world/table"]
    assert "Scalars:scalars" in ents["/metrics/picked"]
    assert "TextLog:text" in ents["/events"]
    assert "/metrics/rate" not in ents and "/metrics/error_mm" not in ents  # None, NaN skipped
    stats = _cli("rrd", "stats", str(path))
    assert stats.returncode == 0, stats.stderr
    for entity in ("/world/overhead_camera/image", "/world/overhead_camera/detections",
                   "/truth/segmentation", "/world/bodies/part_2", "/metrics/picked", "/events"):
        assert f"{entity}:" in stats.stdout


def test_body_poses_come_back_in_rerun_order(tmp_path, scene):
    world = scene[0]
    part = world.parts[0]
    with Replay(tmp_path / "r.rrd", world) as rep:
        for _ in range(3):
            world.step(20)
            rep.log_state(world.time, world)
        pos, quat = world.part_pose(part.id)
    rows = {}
    for chunk in RrdReader(tmp_path / "r.rrd").stream():
        if chunk.entity_path == "/world/bodies/part_1":
            batch = chunk.to_record_batch()
            for t, p, q in zip(batch.column("sim_time").cast("int64").to_pylist(),
                               batch.column("Transform3D:translation").to_pylist(),
                               batch.column("Transform3D:quaternion").to_pylist(), strict=True):
                rows[t] = (p[0], q[0])
    last = rows[max(rows)]
    assert abs(max(rows) - world.time * 1e9) <= 1  # ns
    assert np.allclose(last[0], pos, atol=1e-6)
    assert np.allclose(last[1], [*quat[1:], quat[0]], atol=1e-6)  # xyzw


def test_geometry_is_static_and_leaves_out_collision_geoms(tmp_path, scene, strict):
    world = scene[0]
    path = tmp_path / "r.rrd"
    Replay(path, world).close()
    chunks = list(RrdReader(path).stream())
    assert {c.timeline_names[0] for c in chunks if c.timeline_names} == {"sim_time"}  # the one timeline
    static = {c.entity_path for c in chunks if c.is_static}
    m = world.model
    geoms = [g for g in range(m.ngeom) if m.body(int(m.geom_bodyid[g])).name == "part_2"]
    drawn = {p for p in static if p.startswith("/world/bodies/part_2/")}
    assert drawn == {f"/world/bodies/part_2/g{g}" for g in geoms if m.geom_group[g] != 3}
    assert len(drawn) < len(geoms)  # its collision boxes are not drawn
    assert r"/world/bodies/arm\/base" in static  # fixed to the world
    assert "/world/bodies/part_1" not in static  # moves: on sim_time only


def test_recording_id_follows_the_whole_scenario_and_the_key(tmp_path, scene, module_world_factory):
    # (it came from the scenario's name and seed only: runs of 3 and 6 parts, or on two
    # calibrations, shared one id, and the viewer merged them into one recording)
    world = scene[0]
    other = module_world_factory(seed=2, parts={"count": 1})
    more = module_world_factory(seed=world.scenario.seed, parts={"count": 3})
    reps = {"a": (world, ""), "b": (world, ""), "c": (other, ""), "d": (more, ""), "e": (world, "cal")}
    for name, (w, key) in reps.items():  # (several at once, in one process)
        with Replay(tmp_path / f"{name}.rrd", w, key=key) as rep:
            rep.log_event(w.time, "hello")
    ids = {n: RrdReader(tmp_path / f"{n}.rrd").recordings()[0].recording_id for n in reps}
    assert ids["a"] == ids["b"] == recording_id(world)
    assert len({ids["a"], ids["c"], ids["d"], ids["e"]}) == 4
    assert all(_cli("rrd", "verify", str(tmp_path / f"{n}.rrd")).returncode == 0 for n in reps)


def test_close_moves_the_file_into_place_atomically(tmp_path, scene):
    path = tmp_path / "r.rrd"
    path.write_bytes(b"old")
    rep = Replay(path, scene[0])
    rep.log_event(1.0, "x")
    assert path.read_bytes() == b"old"  # untouched until close
    assert len(list(tmp_path.iterdir())) == 2  # the temporary file beside it
    rep.close()
    assert [p.name for p in tmp_path.iterdir()] == ["r.rrd"]
    assert path.read_bytes() != b"old"
    assert rep.closed
    with pytest.raises(CellError, match="already closed"):
        rep.log_state(2.0, scene[0])


def test_a_finished_replay_waits_for_commit_or_abort(tmp_path, scene):
    path = tmp_path / "r.rrd"
    kept, dropped = Replay(path, scene[0]), Replay(tmp_path / "d.rrd", scene[0])
    for rep in (kept, dropped):
        rep.finish()
        assert rep.closed
    assert not path.exists() and len(list(tmp_path.iterdir())) == 2  # finished, not in place
    kept.commit()
    dropped.abort()
    assert [p.name for p in tmp_path.iterdir()] == ["r.rrd"]
    assert _cli("rrd", "verify", str(path)).returncode == 0


def test_abort_leaves_the_old_file_and_no_temporary(tmp_path, scene):
    path = tmp_path / "r.rrd"
    path.write_bytes(b"old")
    rep = Replay(path, scene[0])
    rep.log_metrics(0.5, {"x": 1.0})
    rep.abort()
    rep.abort()  # twice is harmless
    assert [p.name for p in tmp_path.iterdir()] == ["r.rrd"]
    assert path.read_bytes() == b"old"
    forgotten = Replay(tmp_path / "never_closed.rrd", scene[0])
    del forgotten  # neither closed nor aborted: discarded when collected
    gc.collect()
    assert [p.name for p in tmp_path.iterdir()] == ["r.rrd"]


def test_an_exception_in_the_with_block_aborts(tmp_path, scene):
    path = tmp_path / "r.rrd"
    with pytest.raises(RuntimeError, match="boom"), Replay(path, scene[0]) as rep:
        rep.log_event(0.0, "start")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_bad_paths_are_clear_errors(tmp_path, scene):
    missing = tmp_path / "no" / "such" / "r.rrd"
    with pytest.raises(CellError, match=r"r\.rrd.*cannot write in its folder"):
        Replay(missing, scene[0])
    with pytest.raises(CellError, match="is a directory"):
        Replay(tmp_path, scene[0])
    with pytest.raises(CellError, match="jpeg_quality"):
        Replay(tmp_path / "r.rrd", scene[0], jpeg_quality=0)
    assert list(tmp_path.iterdir()) == []


def test_rerun_switched_off_is_a_clear_error(tmp_path, scene, monkeypatch):
    monkeypatch.setenv("RERUN", "off")
    with pytest.raises(CellError, match="RERUN=off"):
        Replay(tmp_path / "r.rrd", scene[0])
    assert list(tmp_path.iterdir()) == []


def _part_at(seg: np.ndarray, uv) -> int:
    """The part id most seen within 15 px of pixel uv (a washer's centre is its hole)."""
    u, v = round(uv[0]), round(uv[1])
    window = seg[max(v - 15, 0):v + 16, max(u - 15, 0):u + 16]
    return int(np.bincount(window[window > 0]).argmax())


def test_detection_boxes_cover_the_parts(scene):
    world, frame, dets = scene
    assert len(dets) == 2
    for d in dets:
        v, u = np.nonzero(frame.seg == _part_at(frame.seg, d.centroid))
        truth = np.array([np.ptp(u) + 1, np.ptp(v) + 1])
        w, h = _box_size(d, frame.camera, world.scenario.vision.plane_z)
        inside = (np.abs(u - d.centroid[0]) <= w / 2 + 1) & (np.abs(v - d.centroid[1]) <= h / 2 + 1)
        assert inside.mean() > 0.97, d.kind  # the box holds the part
        assert w * h < 1.6 * truth.prod(), d.kind  # and not much more
    partial = SimpleNamespace(**{**dets[0].to_dict(), "position": None})  # size from the centroid's ray
    assert np.allclose(_box_size(partial, frame.camera, 0.08), _box_size(dets[0], frame.camera, 0.08),
                       rtol=0.05)


def test_log_capture_takes_detections_of_other_detectors(tmp_path, scene, strict):
    world, frame, _ = scene
    odd = [SimpleNamespace(centroid=(100.0, 120.0)), SimpleNamespace(kind="disc", size=None),
           SimpleNamespace(centroid=(50.0, 60.0), size=(0.02, 0.01), material="plastic", yaw=0.3)]
    assert _box_size(odd[0], frame.camera, 0.08) == [24.0, 24.0]  # no size: a fixed box
    with Replay(tmp_path / "r.rrd", world, jpeg_quality=50) as rep:
        rep.log_capture(1.0, rgb=frame.rgb, detections=odd, seg=None, camera=frame.camera)
        rep.log_capture(2.0, rgb=frame.rgb, detections=[], seg=None, camera=frame.camera)
        with pytest.raises(CellError, match="uint8"):
            rep.log_capture(3.0, rgb=frame.depth, detections=[], seg=None, camera=frame.camera)
    ents = _entities(tmp_path / "r.rrd")
    assert "/truth/segmentation" not in ents
    assert "Boxes2D:labels" in ents["/world/overhead_camera/detections"]


def test_a_detection_box_is_labelled_with_its_weaker_confidence():
    """The label's confidence is the lower of kind's and material's: a bolt sure of its
    kind (0.9) but not of its material (0.4) must not read as a confident detection."""
    dets = [SimpleNamespace(centroid=(10.0, 20.0), kind="bolt", material="metal", kind_confidence=0.9,
                            material_confidence=0.4),
            SimpleNamespace(centroid=(30.0, 40.0), kind="washer", material="plastic", kind_confidence=0.55,
                            material_confidence=0.8, partial=True)]
    boxes = _boxes(dets, None, 0.08)  # (no size: the fixed box, no camera needed)
    assert boxes.labels.as_arrow_array().to_pylist() == ["bolt metal 0.40", "washer plastic 0.55 partial"]
