"""The colour cut: touching parts of two finishes are told apart by their colours where
their outlines give no cut; one finish, shaded and noisy, is never cut; the compiled
seeds equal the OpenCV/numpy formulation they are written from."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cell.catalogue import KINDS
from cell.vision._blobwindows import blobs_of_mask
from cell.vision._colourcut import colour_seeds
from cell.vision._split import split_blob
from tests.vision.test_split import PLANE_Z, _camera, _view

_K3 = np.ones((3, 3), np.uint8)


def _reference_seeds(img, roi, ox, oy, *, l_weight=0.5, fisher=4.0, share=0.1):
    """colour_seeds in OpenCV and numpy calls: cv2.cvtColor, cv2.erode, Lloyd's 2-means
    from the farthest points, every roi pixel to its nearer centre, cv2.morphologyEx,
    cv2.connectedComponentsWithStats."""
    h, w = roi.shape
    lab = cv2.cvtColor(np.ascontiguousarray(img[oy : oy + h, ox : ox + w]),
                       cv2.COLOR_RGB2LAB).astype(np.float64)
    lab[..., 0] *= l_weight
    inner = cv2.erode(roi, _K3) > 0
    x = lab[inner]
    if len(x) < 60:
        return None
    c = np.stack([x[np.argmax(((x - x.mean(0)) ** 2).sum(1))], np.zeros(3)])
    c[1] = x[np.argmax(((x - c[0]) ** 2).sum(1))]
    for _ in range(10):
        label = (((x - c[1]) ** 2).sum(1) < ((x - c[0]) ** 2).sum(1)).astype(int)
        if label.min() == label.max():
            return None
        new = np.stack([x[label == k].mean(0) for k in (0, 1)])
        moved, c = np.abs(new - c).max(), new
        if moved < 1e-9:
            break
    if min(np.bincount(label, minlength=2)) < share * len(x):
        return None
    spread = ((x - c[label]) ** 2).sum() / len(x)
    if ((c[0] - c[1]) ** 2).sum() < fisher * max(spread, 1e-6):
        return None
    on = roi > 0
    d = ((lab[on][:, None, :] - c[None]) ** 2).sum(2)
    labels = np.zeros((h, w), np.uint8)
    labels[on] = 1 + (d[:, 1] < d[:, 0])
    seeds = np.zeros((h, w), np.uint8)
    for k in (1, 2):
        cluster = cv2.morphologyEx((labels == k).astype(np.uint8), cv2.MORPH_OPEN, _K3)
        n, cc, stats, _ = cv2.connectedComponentsWithStats(cluster, connectivity=8)
        if n < 2:
            return None
        seeds[cc == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))] = k
    return seeds


def _two_finish_blob(rng, colours, *, noise=4.0, shade=0.0):
    """A frame (uint8 RGB 120x160) holding a blob of two touching discs, each of its own
    colour, darkened by ``shade`` from left to right, with Gaussian noise; the blob's roi
    with a blank border and its corner."""
    img = np.full((120, 160, 3), (40, 50, 70), np.float64)
    roi = np.zeros((120, 160), np.uint8)
    for (u, v), colour in zip(((60, 60), (92, 64)), colours, strict=True):
        disc = np.zeros((120, 160), np.uint8)
        cv2.circle(disc, (u, v), 17, 255, -1)
        img[disc > 0] = colour
        roi |= disc
    img *= (1.0 - shade * np.linspace(0, 1, 160))[None, :, None]
    img = np.clip(img + rng.normal(0, noise, img.shape), 0, 255).astype(np.uint8)
    return img, roi


@pytest.mark.parametrize("seed", range(6))
def test_seeds_equal_the_opencv_formulation(seed):
    rng = np.random.default_rng(seed)
    finishes = [(200, 50, 40), (60, 80, 200), (180, 180, 170), (110, 110, 115), (230, 190, 30)]
    a, b = rng.choice(len(finishes), 2, replace=False)
    img, roi = _two_finish_blob(rng, [finishes[a], finishes[b]], noise=rng.uniform(1, 8),
                                shade=rng.uniform(0, 0.4))
    got, want = colour_seeds(img, roi, 0, 0), _reference_seeds(img, roi, 0, 0)
    assert (got is None) == (want is None)
    if want is not None:
        np.testing.assert_array_equal(got, want)


def test_two_finishes_give_one_seed_region_each():
    img, roi = _two_finish_blob(np.random.default_rng(0), [(200, 50, 40), (60, 80, 200)])
    seeds = colour_seeds(img, roi, 0, 0)
    assert seeds is not None
    for k in (1, 2):  # one seed region per disc (which disc is 1 is not fixed)
        assert np.count_nonzero(seeds == k) > 400
    left = seeds[60, 45:75]
    right = seeds[64, 77:107]
    assert len(set(left[left > 0].tolist())) == 1 and len(set(right[right > 0].tolist())) == 1
    assert left[left > 0][0] != right[right > 0][0]


@pytest.mark.parametrize("shade", [0.0, 0.5])
def test_one_finish_shaded_and_noisy_is_not_cut(shade):
    img, roi = _two_finish_blob(np.random.default_rng(1), [(180, 180, 170)] * 2, noise=8.0,
                                shade=shade)
    assert colour_seeds(img, roi, 0, 0) is None


def test_a_roi_leaving_the_frame_is_not_cut():
    img, roi = _two_finish_blob(np.random.default_rng(2), [(200, 50, 40), (60, 80, 200)])
    assert colour_seeds(img, roi, 10, 0) is None


def _square(centre, half, n=4):
    t = np.arange(n) * 2 * math.pi / n + math.pi / 4
    r = half * math.sqrt(2)
    return np.c_[centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)]


@pytest.mark.parametrize("colours", [((200, 50, 40), (60, 80, 200)), ((200, 50, 40),) * 2])
def test_square_nuts_edge_to_edge_are_cut_by_colour_only(colours):
    """Two square nuts edge to edge make a rectangle with two holes: no notch for an
    outline cut, one distance-transform core. Of two finishes they come out as two square
    nuts where they lie; of one finish they are not cut."""
    camera = _camera()
    kind = KINDS["square_nut"]
    half = kind.length / 2
    centres = [(-half, 0.45), (half, 0.45)]
    view = _view(camera)
    mask = np.zeros((480, 640), np.uint8)
    for centre, colour in zip(centres, colours, strict=True):
        top = camera.project(np.c_[_square(centre, half), np.full(4, PLANE_Z + kind.height)])
        part = np.zeros((480, 640), np.uint8)
        cv2.fillPoly(part, [np.round(top).astype(np.int32)], 255)
        u, v = camera.project(np.array([[*centre, PLANE_Z + kind.height]]))[0]
        radius = kind.hole / 2 * camera.K[0, 0] / (camera.T_world_camera[2, 3] - PLANE_Z
                                                    - kind.height)
        cv2.circle(part, (round(u), round(v)), round(radius), 0, -1)
        view.img[part > 0] = colour
        mask |= part
    view.img[mask == 0] = (40, 50, 70)
    blobs = blobs_of_mask(mask, (0, 0))
    assert len(blobs) == 1 and len(blobs[0].holes) == 2
    pieces = split_blob(blobs[0], view)
    if colours[0] == colours[1]:
        assert pieces == []
        return
    assert sorted(p[1] for p in pieces) == ["square_nut", "square_nut"]
    found = sorted(tuple(p[3].fp.centroid) for p in pieces)
    for (x, y), (tx, ty) in zip(found, sorted(centres), strict=True):
        assert math.hypot(x - tx, y - ty) < 1.5e-3
