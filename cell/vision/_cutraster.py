"""The pieces of a rasterised blob around seed regions, every pixel to its nearest seed,
in one compiled pass (numba).

The split stage (:mod:`cell.vision._split`) cuts a blob at the cores of its distance
transform: each pixel of the blob goes to the core nearest to it. Nearness is the 5x5
chamfer distance with labels that ``cv2.distanceTransformWithLabels(..., cv2.DIST_L2,
3, labelType=cv2.DIST_LABEL_PIXEL)`` computes (OpenCV forces the 5x5 mask when labels
are asked for; Borgefors, *Distance transformations in digital images*, CVGIP 34, 1986):
a forward and a backward raster pass in 16-bit fixed point with the weights 1, 1.4 and
2.1969, each pixel taking the label of the neighbour that lowers its distance first, as
``distanceTransformEx_5x5`` in OpenCV's imgproc/src/distransform.cpp does.
``tests/vision/test_cutraster.py`` checks it against OpenCV. :func:`piece_blobs` outlines
the pieces (``cv2.findContours``).
"""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit

from cell.vision._blob import Blob
from cell.vision._blobwindows import joined_blobs, joined_outlines
from cell.vision._footprint import Geometry
from cell.vision._segment_kernel import area_box

__all__: list[str] = []  # private to cell.vision

# cvRound(float32(w) * 2^16) of the L2 5x5 mask's weights (getDistanceTransformMask, 52)
_HV, _DIAG, _LONG = 65536, 91750, 143976
_MAX = 2**32 - 1 - _LONG  # DIST_MAX: unsigned 32-bit, less the longest step


@njit(cache=True, inline="always")
def _relax(t0, l0, tmp, lab, q, step):  # pragma: no cover (compiled)
    """The distance and label of a pixel after trying the neighbour at flat index ``q``
    a ``step`` away: taken only when strictly nearer. (The index is made unsigned: numba
    then leaves out its check for a negative index, which costs 40 % of the pass.)"""
    u = np.uint64(q)
    t = tmp[u] + step
    if t0 > t:
        return t, lab[u]
    return t0, l0


@njit(cache=True)
def _passes(tmp, lab, h, w, st):  # pragma: no cover (compiled)
    """The forward and backward pass over an (h, w) image, in place on its distances
    ``tmp`` and labels ``lab`` (flat, row stride ``st``, a 2-pixel border at ``_MAX``;
    the seed pixels at distance 0 with their labels, the others at ``_MAX``)."""
    for i in range(h):  # forward pass
        for j in range(w):
            q = (i + 2) * st + j + 2
            if tmp[np.uint64(q)] == 0:  # a seed
                continue
            t0, l0 = _relax(_MAX, np.int32(0), tmp, lab, q - 2 * st - 1, _LONG)
            t0, l0 = _relax(t0, l0, tmp, lab, q - 2 * st + 1, _LONG)
            t0, l0 = _relax(t0, l0, tmp, lab, q - st - 2, _LONG)
            t0, l0 = _relax(t0, l0, tmp, lab, q - st - 1, _DIAG)
            t0, l0 = _relax(t0, l0, tmp, lab, q - st, _HV)
            t0, l0 = _relax(t0, l0, tmp, lab, q - st + 1, _DIAG)
            t0, l0 = _relax(t0, l0, tmp, lab, q - st + 2, _LONG)
            t0, l0 = _relax(t0, l0, tmp, lab, q - 1, _HV)
            tmp[np.uint64(q)] = t0
            lab[np.uint64(q)] = l0
    for i in range(h - 1, -1, -1):  # backward pass
        for j in range(w - 1, -1, -1):
            q = (i + 2) * st + j + 2
            t0, l0 = tmp[np.uint64(q)], lab[np.uint64(q)]
            if t0 > _HV:
                t0, l0 = _relax(t0, l0, tmp, lab, q + 2 * st + 1, _LONG)
                t0, l0 = _relax(t0, l0, tmp, lab, q + 2 * st - 1, _LONG)
                t0, l0 = _relax(t0, l0, tmp, lab, q + st + 2, _LONG)
                t0, l0 = _relax(t0, l0, tmp, lab, q + st + 1, _DIAG)
                t0, l0 = _relax(t0, l0, tmp, lab, q + st, _HV)
                t0, l0 = _relax(t0, l0, tmp, lab, q + st - 1, _DIAG)
                t0, l0 = _relax(t0, l0, tmp, lab, q + st - 2, _LONG)
                t0, l0 = _relax(t0, l0, tmp, lab, q + 1, _HV)
                tmp[np.uint64(q)] = t0
                lab[np.uint64(q)] = l0


@njit(cache=True)
def nearest_labels(seeded):  # pragma: no cover (compiled)
    """Per pixel of ``seeded`` (uint8 (H, W), 0 on the seed pixels) the number of its
    nearest seed pixel (1, 2, ... in row-major order), as
    ``cv2.distanceTransformWithLabels(seeded, cv2.DIST_L2, 3,
    labelType=cv2.DIST_LABEL_PIXEL)[1]``."""
    h, w = seeded.shape
    st = w + 4  # the row stride of the distances and labels, with a 2-pixel border
    tmp = np.full((h + 4) * st, _MAX, np.uint32)
    lab = np.zeros((h + 4) * st, np.int32)
    k = 1
    for i in range(h):
        for j in range(w):
            if seeded[i, j] == 0:
                q = np.uint64((i + 2) * st + j + 2)
                tmp[q] = 0
                lab[q] = k
                k += 1
    _passes(tmp, lab, h, w, st)
    out = np.empty((h, w), np.int32)
    for i in range(h):
        for j in range(w):
            out[i, j] = lab[np.uint64((i + 2) * st + j + 2)]
    return out


@njit(cache=True)
def owned_pieces(roi, seeds):  # pragma: no cover (compiled)
    """The pieces of ``roi`` (uint8 0/255) around ``seeds`` (uint8, seed regions
    labelled 1..n, 0 elsewhere): each pixel of the roi goes to the seed region of its
    nearest seed pixel (:func:`nearest_labels`, carrying the regions' numbers instead of
    the pixels': the same choices, a pixel takes a neighbour's label on distances alone).
    Returns the pieces' masks (n, H, W) (uint8 0/255) and their pixel counts (n,)."""
    h, w = seeds.shape
    st = w + 4
    tmp = np.full((h + 4) * st, _MAX, np.uint32)
    lab = np.zeros((h + 4) * st, np.int32)
    n = 0
    for i in range(h):
        for j in range(w):
            s = seeds[i, j]
            if s != 0:
                q = np.uint64((i + 2) * st + j + 2)
                tmp[q] = 0
                lab[q] = s
                n = max(n, np.int64(s))
    _passes(tmp, lab, h, w, st)
    masks = np.zeros((n, h, w), np.uint8)
    counts = np.zeros(n, np.int64)
    for i in range(h):
        for j in range(w):
            if roi[i, j] != 0:
                v = lab[np.uint64((i + 2) * st + j + 2)]
                if v > 0:
                    masks[v - 1, i, j] = 255
                    counts[v - 1] += 1
    return masks, counts


def piece_blobs(masks: np.ndarray, counts: np.ndarray, offset: tuple[int, int],
                geo: Geometry | None = None) -> list[Blob] | None:
    """The blobs of the pieces a cut at the cores gives (``masks`` and ``counts`` from
    :func:`owned_pieces`: every pixel of the blob to its nearest
    seed), each the one outer contour of at least 8 points and 30 px^2 of its mask, with
    holes, as :func:`cell.vision._blobwindows.blobs_of_mask` finds them (all outlined in one
    pass, their outlines, areas and centroids in one compiled call, and given the
    camera's ``geo`` their rays in one more), or None when a piece is a speck or not one
    region."""
    if counts.min() < 30:
        return None
    n, h, w = masks.shape
    # the masks one below the other, outlined in one pass: each has a blank border (the
    # roi's), so no contour crosses from one to the next, and each mask's contours come
    # in its own order, with its own hierarchy
    contours, hr = cv2.findContours(masks.reshape(n * h, w), cv2.RETR_CCOMP,
                                    cv2.CHAIN_APPROX_NONE)
    if hr is None:
        return None
    lengths = np.fromiter(map(len, contours), np.int64, len(contours))
    found, rows, areas, holes, outline, normals = _pieces(
        np.concatenate(contours).reshape(-1, 2), lengths, hr[0], n, h, offset[0], offset[1])
    if not found:
        return None
    subs = joined_blobs(rows, areas, holes, outline, normals, geo)
    for sub, mask in zip(subs, masks, strict=True):
        sub.roi = (offset[0], offset[1], mask)
    return subs


@njit(cache=True)
def _pieces(pts, lengths, hier, n, h, ox, oy):  # pragma: no cover (compiled)
    """(found, rows, areas, holes, outline, normals) of :func:`piece_blobs`: each of the
    ``n`` masks (bands of ``h`` rows, stacked) must hold exactly one outer contour of at
    least 8 points and 30 px^2 (``cv2.contourArea``: twice it is the shoelace sum, exact
    on pixels), else ``found`` is False; ``rows`` (n, 9) as
    :func:`~cell.vision._blobwindows.joined_blobs` takes them (the frame box of each, the
    band moved to (``ox``, ``oy``)), the rest as
    :func:`~cell.vision._blobwindows.joined_outlines` gives them."""
    m = lengths.shape[0]
    starts = np.zeros(m + 1, np.int64)
    for i in range(m):
        starts[i + 1] = starts[i] + lengths[i]
    outer = np.full(n, -1, np.int64)
    rows = np.zeros((n, 9), np.int64)
    shifts = np.empty((n, 2), np.int64)
    for i in range(m):
        if hier[i, 3] != -1 or lengths[i] < 8:
            continue
        area, x0, y0, x1, y1 = area_box(pts, starts[i], starts[i + 1])
        if area < 60:
            continue
        band = np.int64(pts[starts[i], 1]) // h
        if outer[band] >= 0:  # a mask with two
            return (False, rows[:0], np.empty((0, 3)), np.empty((0, 2), np.int64),
                    np.empty((0, 2)), np.empty((0, 2)))
        outer[band] = i
        shifts[band, 0], shifts[band, 1] = ox, oy - band * h
        rows[band, 0], rows[band, 1] = x0 + ox, y0 - band * h + oy
        rows[band, 2], rows[band, 3] = x1 - x0 + 1, y1 - y0 + 1
    if outer.min() < 0:
        return (False, rows[:0], np.empty((0, 3)), np.empty((0, 2), np.int64),
                np.empty((0, 2)), np.empty((0, 2)))
    areas, holes, outline, normals = joined_outlines(pts, starts, hier, outer, shifts,
                                                     rows[:, 5:])
    return True, rows, areas, holes, outline, normals
