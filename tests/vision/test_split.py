"""Touching parts cut apart: two discs side by side come out as two discs where they lie,
and a blob that is no set of parts is given up within the cut budget; the pieces' compiled
centroid is ``cv2.moments``' to the last bit."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

import cell.vision._split as split_module
from cell.camera import CameraModel
from cell.catalogue import KINDS
from cell.vision._blobwindows import blobs_of_mask
from cell.vision._centroid import blob_centroid
from cell.vision._footprint import Geometry
from cell.vision._segment import FrameView
from cell.vision._split import split_blob
from cell.vision.settings import VisionSettings

PLANE_Z = 0.08


def _camera(dist: np.ndarray | None = None) -> CameraModel:
    K = np.array([[660.0, 0, 319.5], [0, 660.0, 239.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = (0.0, 0.45, 0.48)
    return CameraModel(640, 480, K, np.zeros(5) if dist is None else dist, T)


def _view(camera: CameraModel) -> FrameView:
    img = np.zeros((480, 640, 3), np.uint8)
    geo = Geometry(camera, PLANE_Z)
    return FrameView(img, np.zeros((60, 80, 3), np.uint8), np.zeros((240, 320), np.uint8),
                     np.zeros((240, 320), np.uint8), 10.0, 0, False, geo, VisionSettings(),
                     max_px=400, min_px=50.0)


def _mask_of(camera: CameraModel, polygons_world: list[np.ndarray], height: float) -> np.ndarray:
    """A 480x640 mask of world polygons (metres, on the plane ``height`` above the belt)."""
    mask = np.zeros((480, 640), np.uint8)
    for poly in polygons_world:
        px = camera.project(np.c_[poly, np.full(len(poly), PLANE_Z + height)])
        cv2.fillPoly(mask, [np.round(px).astype(np.int32)], 255)
    return mask


def _disc(centre, radius=0.015, n=120) -> np.ndarray:
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.c_[centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t)]


@pytest.mark.parametrize("dist", [None, np.array([-0.12, 0.05, 0.001, -0.0005, 0.0])])
def test_two_touching_discs_come_out_as_two_discs_where_they_lie(dist):
    """Also through a distorting lens (the cuts' rays then come from undistorted points)."""
    camera = _camera(dist)
    centres = [(-0.02, 0.45), (0.0105, 0.452)]  # 30.5 mm apart: just touching in the image
    h = KINDS["disc"].height
    mask = _mask_of(camera, [_disc(c) for c in centres], h)
    blobs = blobs_of_mask(mask, (0, 0))
    assert len(blobs) == 1  # one blob of two parts
    pieces = split_blob(blobs[0], _view(camera))
    assert sorted(p[1] for p in pieces) == ["disc", "disc"]
    found = sorted(tuple(p[3].fp.centroid) for p in pieces)
    for (x, y), (tx, ty) in zip(found, sorted(centres), strict=True):
        assert math.hypot(x - tx, y - ty) < 1.5e-3


@pytest.mark.parametrize("skip", [0.0, 0.7])
def test_the_raster_cores_are_tried_only_when_the_outline_cuts_fit_poorly(monkeypatch, skip):
    """With every cut tried (no early stop at a good fit), two touching discs' outline cut
    fits well below the skip fraction of the limit, so the distance transform's cores are
    not computed; with no skip they are, and the answer is the same two discs."""
    camera = _camera()
    mask = _mask_of(camera, [_disc((-0.02, 0.45)), _disc((0.0105, 0.452))], KINDS["disc"].height)
    blobs = blobs_of_mask(mask, (0, 0))
    calls = {"n": 0}
    core_cuts = split_module._core_cuts

    def count_core_cuts(roi):
        calls["n"] += 1
        return core_cuts(roi)

    monkeypatch.setattr(split_module, "_core_cuts", count_core_cuts)
    monkeypatch.setattr(split_module, "_GOOD", 0.0)
    monkeypatch.setattr(split_module, "_CORE_SKIP", skip)
    pieces = split_blob(blobs[0], _view(camera))
    assert sorted(p[1] for p in pieces) == ["disc", "disc"]
    assert calls["n"] == (1 if skip == 0.0 else 0)


def test_a_blob_of_no_parts_is_given_up_within_the_budget(monkeypatch):
    """A jagged star (no catalogue kind, many deep notches) costs at most the budget of
    evaluated cuts, then comes back as no parts."""
    camera = _camera()
    rng = np.random.default_rng(3)
    t = np.linspace(0, 2 * math.pi, 18, endpoint=False)
    r = np.where(np.arange(18) % 2, 0.012, 0.03) * rng.uniform(0.8, 1.2, 18)
    star = np.c_[r * np.cos(t), 0.45 + r * np.sin(t)]
    blobs = blobs_of_mask(_mask_of(camera, [star], 0.003), (0, 0))
    calls = {"n": 0}
    pieces, evaluate = split_module._batch_pieces, split_module._evaluate

    def count_pieces(*a, **k):  # an outline cut
        calls["n"] += 1
        return pieces(*a, **k)

    def count_evaluate(subs, view, may_split):  # a raster cut
        calls["n"] += 1
        return evaluate(subs, view, may_split)

    monkeypatch.setattr(split_module, "_batch_pieces", count_pieces)
    monkeypatch.setattr(split_module, "_evaluate", count_evaluate)
    assert split_blob(blobs[0], _view(camera)) == []
    assert 4 <= calls["n"] <= split_module._BUDGET  # it did search, and stopped in budget


@pytest.mark.parametrize("kind", ["washer", "hex_nut"])
def test_a_single_part_blob_is_not_cut(kind):
    """A blob that is one part (not a pair) yields no cut whose pieces fit."""
    camera = _camera()
    size = KINDS[kind].length / 2
    t = np.linspace(0, 2 * math.pi, 6 if kind == "hex_nut" else 90, endpoint=False)
    outline = np.c_[size * np.cos(t), 0.45 + size * np.sin(t)]
    blobs = blobs_of_mask(_mask_of(camera, [outline], KINDS[kind].height), (0, 0))
    assert split_blob(blobs[0], _view(camera)) == []



@pytest.mark.parametrize("holes", [0, 1, 2])
def test_outline_pieces_carry_blob_centroid_and_area_to_the_last_bit(holes):
    """Every piece the compiled outline cuts give (of two touching washers, with up to
    two holes) comes with the centroid of ``blob_centroid`` and the area of
    ``Geometry.area_mm2``, equal to the last bit."""
    camera = _camera()
    view = _view(camera)
    centres = (-0.02, 0.45), (0.0105, 0.452)
    mask = _mask_of(camera, [_disc(c) for c in centres], 0.002)
    for r in [_disc(c, 0.005) for c in centres][:holes]:
        px = camera.project(np.c_[r, np.full(len(r), PLANE_Z + 0.002)])
        cv2.fillPoly(mask, [np.round(px).astype(np.int32)], 0)
    blob = blobs_of_mask(mask, (0, 0))[0]
    assert len(blob.holes) == holes
    seen = 0
    for pieces in split_module._polygon_cuts(blob, view.geo, 0.5, True, [24]):
        for p in pieces or ():
            carried = p[0].centroid_px  # (computed again from the outline alone:)
            assert carried == blob_centroid(dataclasses.replace(p[0], centroid_px=None))
            assert p[5] == view.geo.area_mm2(p[0])
            seen += 1
    assert seen >= 2
