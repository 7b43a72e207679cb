"""PartDetector on rendered frames (test seeds < 1000) and on degenerate frames."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cell.catalogue import KINDS
from cell.errors import VisionError
from cell.sim import layout
from cell.vision.detector import Detection, PartDetector
from cell.vision.settings import VisionSettings

P = layout.PICK_ZONE


def _scene(factory, seed, placements, kinds, materials, lighting="front"):
    """A world whose parts (kinds x materials, in order) are placed at (dx, dy, yaw)."""
    w = factory(seed=seed, lighting=lighting,
                parts={"count": len(placements), "kinds": kinds, "materials": materials})
    for dx, dy, yaw in placements:
        w.place_next_part(P[0] + dx, P[1] + dy, yaw)
    w.step(100)
    return w


def _match(world, dets, pid):
    pos, _ = world.part_pose(pid)
    best = min(dets, key=lambda d: math.inf if d.position is None else
               math.hypot(d.position[0] - pos[0], d.position[1] - pos[1]))
    return best, math.hypot(best.position[0] - pos[0], best.position[1] - pos[1])


@pytest.fixture(scope="module")
def spread(module_world_factory):
    """One part of each kind (seed 21 draws all six), apart, in steel and grey plastic."""
    placements = [(-0.12, -0.03, 0.3), (-0.06, 0.03, 1.1), (0.0, -0.03, 2.0),
                  (0.06, 0.03, 0.7), (0.12, -0.03, 2.6), (0.10, 0.035, 4.0)]
    return _scene(module_world_factory, 21, placements, list(KINDS), ["steel", "plastic_grey"])


@pytest.mark.parametrize("lighting", ["front", "glare"])
def test_every_kind_found_named_and_located(spread, lighting):
    spread.set_lighting(lighting)
    frame = spread.render(depth=False, seg=False)
    dets = PartDetector().detect(frame.rgb, frame.camera)
    assert len(dets) == len(spread.parts)
    for part in spread.parts:
        d, err = _match(spread, dets, part.id)
        assert err < 1e-3, f"{part.kind}: position error {err * 1e3:.2f} mm"
        assert d.kind == part.kind
        assert d.material == part.material, f"{part.finish} read as {d.material}"
        assert d.symmetry == KINDS[part.kind].symmetry
        assert not d.partial and not d.defect
        sym = KINDS[part.kind].symmetry
        if sym:
            period = 2 * math.pi / sym
            e = (d.yaw - spread.part_yaw(part.id)) % period
            assert min(e, period - e) < math.radians(3), f"{part.kind} yaw"
        length = KINDS[part.kind].length
        assert abs(d.size[0] - length) < 2.5e-3


def test_back_light_gives_unknown_material_never_wrong(spread):
    spread.set_lighting("back")
    frame = spread.render(depth=False, seg=False)
    dets = PartDetector().detect(frame.rgb, frame.camera)
    assert len(dets) == len(spread.parts)
    assert all(d.material == "unknown" for d in dets)
    assert sorted(d.kind for d in dets) == sorted(p.kind for p in spread.parts)


def test_touching_parts_come_out_as_two(world_factory):
    w = _scene(world_factory, 12, [(-0.02, 0.0, 0.0), (0.0, 0.0, 0.5)], ["washer"],
               ["plastic_red", "aluminium"])
    seg = w.render(depth=False).seg
    grown = np.zeros_like(seg, dtype=bool)
    grown[:, 1:] |= seg[:, :-1] == 1
    assert (grown & (seg == 2)).any(), "the scene must really have touching washers"
    frame = w.render(depth=False, seg=False)
    dets = PartDetector().detect(frame.rgb, frame.camera)
    assert len(dets) == 2
    for part in w.parts:
        d, err = _match(w, dets, part.id)
        assert err < 1e-3 and d.kind == "washer" and d.material == part.material


def test_part_at_image_border_is_partial_without_position(world_factory):
    w = _scene(world_factory, 13, [(0.19, 0.0, 0.0), (0.0, 0.0, 0.0)], ["disc"], ["plastic_blue"])
    frame = w.render(depth=False, seg=False)
    dets = PartDetector().detect(frame.rgb, frame.camera)
    partial = [d for d in dets if d.partial]
    whole = [d for d in dets if not d.partial]
    assert len(partial) == 1 and partial[0].position is None
    assert len(whole) == 1 and whole[0].kind == "disc"


@pytest.fixture(scope="module")
def empty_frame(module_world_factory):
    w = module_world_factory(seed=14, parts={"count": 1})
    return w.render(depth=False, seg=False)


@pytest.mark.parametrize("kind", ["empty", "black", "saturated", "noise", "salt_pepper"])
def test_degenerate_frames_give_no_detections(empty_frame, kind):
    rng = np.random.default_rng(0)
    img = empty_frame.rgb.copy()
    if kind == "black":
        img[:] = 0
    elif kind == "saturated":
        img[:] = 255
    elif kind == "noise":
        img = rng.integers(0, 256, img.shape, dtype=np.uint8)
    elif kind == "salt_pepper":
        hit = rng.random(img.shape[:2]) < 0.05
        img[hit] = rng.choice([0, 255], size=(int(hit.sum()), 1)).astype(np.uint8)
    assert PartDetector().detect(img, empty_frame.camera) == []


def test_bad_arguments_name_the_culprit(empty_frame):
    det = PartDetector()
    with pytest.raises(VisionError, match="image"):
        det.detect(empty_frame.rgb[..., 0], empty_frame.camera)
    with pytest.raises(VisionError, match="image"):
        det.detect(empty_frame.rgb.astype(np.float32), empty_frame.camera)
    with pytest.raises(VisionError, match="camera"):
        det.detect(empty_frame.rgb, "camera.json")
    with pytest.raises(VisionError, match="camera"):
        det.detect(empty_frame.rgb[:240, :320].copy(), empty_frame.camera)
    with pytest.raises(VisionError, match="settings"):
        PartDetector({"threshold_value": 3})


def test_fixed_and_otsu_thresholds_also_work(spread):
    spread.set_lighting("front")
    frame = spread.render(depth=False, seg=False)
    for method in ("fixed", "otsu"):
        settings = VisionSettings(threshold_method=method, threshold_value=30)
        dets = PartDetector(settings).detect(frame.rgb, frame.camera)
        assert sorted(d.kind for d in dets) == sorted(p.kind for p in spread.parts), method


def test_detection_to_dict_is_json_ready(spread):
    frame = spread.render(depth=False, seg=False)
    d = PartDetector().detect(frame.rgb, frame.camera)[0]
    assert isinstance(d, Detection)
    out = d.to_dict()
    assert set(out) >= {"id", "material", "kind", "centroid", "yaw", "position", "size", "partial"}
    assert isinstance(out["centroid"], list)


# --- the detector's private steps, against references -----------------------------------


def test_background_window_is_the_full_scale_background_there():
    """The background of a window, from the small pixels around it only, is what scaling
    the whole 1/8-scale estimate up to full scale (cv2.resize, bilinear) gives there."""
    import cv2

    from cell.vision._segment import FrameView

    rng = np.random.default_rng(3)
    small = rng.integers(0, 256, (60, 80, 3), dtype=np.uint8)
    full = cv2.resize(small, (640, 480), interpolation=cv2.INTER_LINEAR)
    view = FrameView(np.zeros((480, 640, 3), np.uint8), small, None, None, 10.0, 0, False,
                     None, VisionSettings(), 100, 10.0)
    for x0, y0, x1, y1 in ((0, 0, 37, 21), (100, 50, 180, 130), (601, 455, 640, 480),
                           (8, 8, 9, 9)):
        assert np.array_equal(view.background_at(x0, y0, x1, y1), full[y0:y1, x0:x1])


def test_median_and_mad_from_histogram_match_numpy():
    from cell.vision._segment import _median_mad

    rng = np.random.default_rng(4)
    img = np.clip(rng.normal(20, 5, (96, 128)), 0, 255).astype(np.uint8)
    med, mad = _median_mad(img)
    sample = np.sort(img[2::4, 2::4].ravel())
    lower_median = float(sample[(sample.size - 1) // 2])
    dev = np.sort(np.abs(sample.astype(int) - int(med)))
    assert med == lower_median
    assert mad == pytest.approx(dev[(dev.size - 1) // 2] * 1.4826)


def test_outline_normals_point_out_of_the_region_and_into_holes():
    import cv2

    from cell.vision._blobwindows import blobs_of_mask

    mask = np.zeros((60, 60), np.uint8)
    cv2.rectangle(mask, (10, 10), (49, 49), 255, -1)
    cv2.rectangle(mask, (25, 25), (34, 34), 0, -1)
    (blob,) = blobs_of_mask(mask, (100, 200))
    centre = np.array([129.5, 229.5])  # of both squares, in the frame
    assert np.all(np.einsum("ij,ij->i", blob.normals, blob.contour - centre) > 0)
    (hole, hole_n), = blob.holes
    assert np.all(np.einsum("ij,ij->i", hole_n, hole - centre) < 0)  # into the hole
    area = cv2.contourArea(blob.contour.astype(np.float32)) - cv2.contourArea(
        hole.astype(np.float32))
    assert area == pytest.approx(cv2.countNonZero(mask), rel=0.02)  # half-pixel shift
    assert blob.mask_box == (110, 210, 40, 40)


def test_outline_normals_are_the_turned_five_point_tangents():
    """Normals equal the central difference over five points turned by 90 degrees and
    normalised (the short-contour path computes it the direct way)."""
    from cell.vision._blob import outline_normals

    t = np.linspace(0, 2 * np.pi, 23, endpoint=False)
    pts = np.round(np.stack([50 + 20 * np.cos(t), 40 + 12 * np.sin(t)], 1)).astype(np.int32)
    for p, hole in ((pts, False), (pts[::-1], False), (pts, True)):
        out, n = outline_normals(p, hole=hole)
        q = p.astype(np.float64)
        tan = np.roll(q, -2, axis=0) - np.roll(q, 2, axis=0)
        ref = np.stack([tan[:, 1], -tan[:, 0]], 1) / np.hypot(tan[:, 0], tan[:, 1])[:, None]
        centre = q.mean(axis=0)
        outward = np.einsum("ij,ij->i", ref, q - centre) > 0
        ref = ref if outward.mean() > 0.5 else -ref
        assert np.allclose(n, -ref if hole else ref, atol=1e-12)
        assert np.allclose(out, q + 0.5 * n)
        assert np.array_equal(outline_normals(p[:4], hole=hole)[1].shape, (4, 2))


def test_shadow_dropped_in_the_mask_box_equals_the_whole_image_shadow():
    """Testing shadow only in the mask's bounding box (and a pixel around it) clears the
    same pixels as testing the whole image, also where that box meets the image edge."""
    from cell.vision._segment import _drop_shadow, shadow

    rng = np.random.default_rng(5)
    bg = np.broadcast_to(rng.integers(120, 220, (1, 1, 3)), (40, 50, 3)).astype(np.uint8)
    scale = rng.uniform(0.4, 0.8, (40, 50, 1))  # darker: a shadow ...
    tint = rng.choice([1.0, 1.3], (40, 50, 3))  # ... unless the colour changes
    img = np.clip(bg * scale * tint, 0, 255).astype(np.uint8)
    for box in ((slice(5, 30), slice(8, 20)), (slice(0, 40), slice(0, 12)),
                (slice(33, 40), slice(44, 50))):
        keep = np.zeros((40, 50), np.uint8)
        keep[box] = 255
        ref = keep.copy()
        ref[shadow(img, bg, 0.1)] = 0
        _drop_shadow(keep, img, bg, 0.1)
        assert np.array_equal(keep, ref)
        assert (ref[box] == 0).any()


def test_every_8th_pixel_is_the_strided_slice_for_any_size():
    from cell.vision._segment import _every_8th

    rng = np.random.default_rng(6)
    for h, w in ((480, 640), (21, 21), (16, 16), (100, 131), (37, 45), (5, 9)):
        img = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
        small = _every_8th(img)
        assert small.flags.c_contiguous
        assert np.array_equal(small, img[4::8, 4::8])


def test_same_frame_same_detections_from_any_detector(spread):
    """Detection is a function of the frame: two detectors, and one detector after other
    frames, give identical results (no state carried between frames)."""
    spread.set_lighting("dim")
    dim = spread.render(depth=False, seg=False)
    spread.set_lighting("raking")
    frame = spread.render(depth=False, seg=False)
    spread.set_lighting("front")
    first = PartDetector()
    a = [d.to_dict() for d in first.detect(frame.rgb, frame.camera)]
    first.detect(dim.rgb, dim.camera)  # another frame in between
    b = [d.to_dict() for d in first.detect(frame.rgb, frame.camera)]
    c = [d.to_dict() for d in PartDetector().detect(frame.rgb, frame.camera)]
    assert a and a == b == c
