"""The compiled blobs of a mosaic of windows against their reference, written with
OpenCV: ``cv2.contourArea`` and ``cv2.boundingRect`` for the fragments and boxes,
``cv2.connectedComponents`` for each blob's own pixels and
:func:`make_blobs` (gathering them one by one) for outlines, normals and holes; areas and
centroids as the detector computes them for a blob alone."""

from __future__ import annotations

from bisect import bisect_right

import cv2
import numpy as np
import pytest

from cell.vision._blob import Blob, _normals
from cell.vision._blobwindows import blobs_of_windows
from cell.vision._centroid import blob_centroid
from cell.vision._contours import contours
from cell.vision._mosaic import Mosaic
from cell.vision._polygons import polygon_area


def make_blobs(contours, hier, outer: list[int], offsets: list[tuple[int, int]],
               partial: list[bool], boxes: list[tuple[int, int, int, int]]) -> list[Blob]:
    """The blobs of outer contours ``outer`` of a ``cv2.findContours`` result
    (RETR_CCOMP), each with its holes (children of at least 6 points), gathered one by
    one: contour ``outer[k]`` lies in a crop at ``offsets[k]`` (x0, y0) in the frame and
    has the frame bounding box ``boxes[k]`` (x, y, w, h); outlines and normals from
    :func:`cell.vision._blob._normals` (tested against ``outline_normals``)."""
    members, meta = [], []  # each blob's outline, then its holes; (length, hole, shift)
    for i, (sx, sy) in zip(outer, offsets, strict=True):
        c = contours[i]
        members.append(c)
        meta.append((len(c), 0, sx, sy))
        j = hier[i][2]
        while j != -1:
            c = contours[j]
            if len(c) >= 6:
                members.append(c)
                meta.append((len(c), 1, sx, sy))
            j = hier[j][0]
    outline, normals = np.empty((2, sum(m[0] for m in meta), 2))
    _normals(np.concatenate(members).reshape(-1, 2), np.array(meta, np.int64), outline,
             normals)
    blobs: list[Blob] = []
    start = 0
    for n, is_hole, _, _ in meta:
        piece = outline[start : start + n], normals[start : start + n]
        start += n
        if is_hole:
            blobs[-1].holes.append(piece)
        else:
            k = len(blobs)
            blobs.append(Blob(piece[0], piece[1], [], boxes[k], partial[k]))
    return blobs



def _reference(mos, sub, cs, hier, shape, margin, min_area):
    """What blobs_of_windows computes, one OpenCV call at a time."""
    h, w = shape
    hr = hier.tolist()
    outer = [j for j in range(len(cs)) if hr[j][3] == -1]
    xs = [mx for mx, _ in mos.at_list]  # (the window a contour starts in)
    box_of = [bisect_right(xs, int(cs[j][0, 0, 0])) - 1 for j in outer]
    n_outer = [box_of.count(k) for k in range(len(mos.boxes))]
    picks, offsets, partial, boxes, rois = [], [], [], [], []
    for o in sorted(range(len(outer)), key=box_of.__getitem__):
        j, k = outer[o], box_of[o]
        if len(cs[j]) < 8 or cv2.contourArea(cs[j]) < min_area:
            continue
        x0, y0, x1, y1 = mos.boxes[k]
        mx, my = mos.at_list[k]
        bx, by, bw, bh = cv2.boundingRect(cs[j])
        bx, by = bx - mx + x0, by - my + y0
        picks.append(j)
        offsets.append((x0 - mx, y0 - my))
        partial.append(bx <= margin or by <= margin or bx + bw >= w - margin
                       or by + bh >= h - margin)
        boxes.append((bx, by, bw, bh))
        win = mos.window(sub, k)
        if n_outer[k] == 1:
            own = win.copy()
        else:
            labels = cv2.connectedComponents(win, connectivity=8)[1]
            px, py = int(cs[j][0, 0, 0]) - mx, int(cs[j][0, 0, 1]) - my
            own = (labels == labels[py, px]).astype(np.uint8) * 255
        rois.append((x0, y0, own, n_outer[k] > 1))
    blobs = make_blobs(cs, hr, picks, offsets, partial, boxes) if picks else []
    for blob, (x0, y0, own, several) in zip(blobs, rois, strict=True):
        blob.roi = (x0, y0, own)
        blob.shared = several  # (a window with other blobs: its own pixels labelled)
    return blobs


def geo_free_area(blob) -> float:
    """The blob's area in px^2 as ``Geometry.area_mm2`` sums it."""
    a = polygon_area(blob.contour)
    for h, _ in blob.holes:
        a -= polygon_area(h)
    return a


def assert_same_blob(a, b) -> None:
    """Blob ``a`` (from a joined pass) equals ``b`` (built one contour at a time): box,
    outline, normals, holes, and the area and centroid computed from ``b``'s outline."""
    assert a.mask_box == b.mask_box and a.partial == b.partial
    np.testing.assert_array_equal(a.contour, b.contour)
    np.testing.assert_allclose(a.normals, b.normals, rtol=1e-9, atol=1e-12)
    assert len(a.holes) == len(b.holes)
    for (ha, na), (hb, nb) in zip(a.holes, b.holes, strict=True):
        np.testing.assert_array_equal(ha, hb)
        np.testing.assert_allclose(na, nb, rtol=1e-9, atol=1e-12)
    assert a.area_px == pytest.approx(geo_free_area(b), rel=1e-9)
    assert a.centroid_px == pytest.approx(blob_centroid(b), rel=1e-9)  # (b's computed from its outline)


def _mosaic(seed: int):
    """A mosaic of 3 to 6 windows of a 480x640 frame, each with a few touching or apart
    blobs (some with holes, some specks), at random places."""
    rng = np.random.default_rng(seed)
    boxes = []
    for _ in range(int(rng.integers(3, 7))):
        x0, y0 = 2 * int(rng.integers(0, 290)), 2 * int(rng.integers(0, 210))
        boxes.append((x0, y0, x0 + 2 * int(rng.integers(10, 40)), y0 + 2 * int(rng.integers(10, 30))))
    mos = Mosaic(boxes, 2)
    sub = np.zeros(mos.shape, np.uint8)
    for k, (x0, y0, x1, y1) in enumerate(boxes):
        win = mos.window(sub, k)
        for _ in range(int(rng.integers(1, 4))):
            centre = (int(rng.integers(0, x1 - x0)), int(rng.integers(0, y1 - y0)))
            axes = (int(rng.integers(1, 25)), int(rng.integers(1, 20)))
            cv2.ellipse(win, centre, axes, float(rng.integers(0, 180)), 0, 360, 255, -1)
        win[rng.random(win.shape) < 0.03] = 0  # holes and ragged edges
    cs, hier = cv2.findContours(sub, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    return mos, sub, cs, hier[0]


def test_blobs_of_windows_are_the_opencv_reference():
    compared = holes = shared = 0
    for seed in range(40):
        mos, sub, cs, hier = _mosaic(seed)
        for margin, min_area in ((3, 20.0), (40, 5.0)):
            got = blobs_of_windows(mos, sub, *contours(sub), (480, 640), margin, min_area)
            ref = _reference(mos, sub, cs, hier, (480, 640), margin, min_area)
            assert len(got) == len(ref)
            for a, b in zip(got, ref, strict=True):
                assert_same_blob(a, b)
                assert a.roi[:2] == b.roi[:2]
                np.testing.assert_array_equal(a.roi[2], b.roi[2])
                holes += len(a.holes)
                compared += 1
            shared += sum(1 for b in ref if b.roi[2].any() and getattr(b, "shared", False))
    assert compared > 100 and holes > 20 and shared > 20  # the cases are not all trivial


def test_no_contours_no_blobs():
    mos = Mosaic([(0, 0, 20, 20)], 2)
    sub = np.zeros(mos.shape, np.uint8)
    assert blobs_of_windows(mos, sub, *contours(sub), (480, 640), 3, 1.0) == []
