"""The blobs of a mosaic of refined windows (:mod:`cell.vision._mosaic`), in one compiled
pass over its traced contours.

For every window, in order, its outer contours (``cv2.findContours``, ``RETR_CCOMP``) in
the order traced: fragments are left out; each other one becomes a blob with its holes
(of at least 6 points), its frame bounding box, whether it is partial, its outline and
normals (:func:`cell.vision._blob._normals`), its area and pixel centroid (as
``Geometry.area_mm2`` and :func:`~cell.vision._centroid.blob_centroid` compute them, term
by term) and its own pixels: the whole window when the window holds one outer contour,
else the 8-connected region of the contour's first pixel (what
``cv2.connectedComponents(window, connectivity=8)`` labels alike). The rays of all the
blobs' points to the table plane are then computed in one call.

:func:`joined_outlines` and :func:`joined_blobs` (outlines, areas, centroids, then the
``Blob`` objects and their rays, of chosen contours) serve the split stage's raster
pieces too (:mod:`cell.vision._cutraster`).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numba import njit

from cell.vision._blob import Blob, _normals
from cell.vision._centroid import _moments
from cell.vision._footprint import Geometry
from cell.vision._mosaic import Mosaic
from cell.vision._polygons import polygon_area
from cell.vision._segment_kernel import area_box

__all__: list[str] = []  # private to cell.vision


def blobs_of_windows(mos: Mosaic, sub: np.ndarray, pts: np.ndarray, starts: np.ndarray,
                     hier: np.ndarray, shape: tuple[int, int], margin: int, min_area: float,
                     geo: Geometry | None = None) -> list[Blob]:
    """Blobs of the outer contours of ``sub`` (uint8 0/255) as
    :func:`~cell.vision._contours.contours` gives them (``cv2.findContours``,
    ``RETR_CCOMP``: contour i is ``pts[starts[i]:starts[i + 1]]``, its hierarchy ``hier``
    (n, 4) int32), a mosaic ``mos`` of windows of a frame of ``shape`` (H, W),
    window by window: those of at least 8 points and ``min_area`` px^2, partial within
    ``margin`` px of the frame's edge, each with its own pixels (uint8 0/255, its
    window's shape) as ``roi``. Given the camera's ``geo``, each blob is also prepared
    (:meth:`~cell.vision._footprint.Geometry.prepare`), all in one pass."""
    if not len(hier):
        return []
    boxes = np.array(mos.boxes, np.int64)
    rows, windows, areas, holes, outline, normals, rois = _window_blobs(
        pts, starts, hier, mos.at, boxes, sub, margin, 2.0 * min_area, shape[0], shape[1])
    blobs = joined_blobs(rows, areas, holes, outline, normals, geo)
    for blob, (k, r0) in zip(blobs, windows.tolist(), strict=True):
        x0, y0, x1, y1 = mos.boxes[k]
        blob.roi = (x0, y0, rois[r0 : r0 + (y1 - y0) * (x1 - x0)].reshape(y1 - y0, x1 - x0))
    return blobs


def blobs_of_mask(piece: np.ndarray, offset: tuple[int, int]) -> list[Blob]:
    """Blobs (outer contours of at least 8 points and 30 px^2, with holes) of a uint8
    mask crop whose top-left corner is at ``offset`` in the frame."""
    contours, hier = cv2.findContours(piece, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    if hier is None:
        return []
    hr = hier[0]
    outer = [i for i, c in enumerate(contours)
             if hr[i, 3] == -1 and len(c) >= 8 and cv2.contourArea(c) >= 30]
    if not outer:
        return []
    rows = np.zeros((len(outer), 9), np.int64)
    for k, i in enumerate(outer):
        bx, by, bw, bh = cv2.boundingRect(contours[i])
        rows[k, :4] = bx + offset[0], by + offset[1], bw, bh
    starts = np.zeros(len(contours) + 1, np.int64)
    np.cumsum(np.fromiter(map(len, contours), np.int64, len(contours)), out=starts[1:])
    areas, holes, outline, normals = joined_outlines(
        np.concatenate(contours).reshape(-1, 2), starts, hr, np.array(outer, np.int64),
        np.tile(np.array(offset, np.int64), (len(outer), 1)), rows[:, 5:])
    return joined_blobs(rows, areas, holes, outline, normals, None)


def joined_blobs(rows: np.ndarray, areas: np.ndarray, holes: np.ndarray, outline: np.ndarray,
                 normals: np.ndarray, geo: Geometry | None) -> list[Blob]:
    """The ``Blob`` of each row of ``rows`` (B, 9) int64: frame box x, y, w, h, partial
    (0/1) and, as :func:`joined_outlines` gives them, its outline's rows [start, end), its
    first hole's row in ``holes`` and its hole count; with its area and pixel centroid
    from ``areas`` (B, 3) and, given the camera's ``geo``, its rays to the table plane (as
    :meth:`~cell.vision._footprint.Geometry.prepare` leaves them; all points in one call)."""
    rays = away = None
    if geo is not None and len(outline):
        rays, away = geo.plane_rays(outline, normals)
    out = []
    for (bx, by, bw, bh, partial, start, end, h0, n_h), (area, u, v) in zip(
            rows.tolist(), areas.tolist(), strict=True):
        blob = Blob(outline[start:end], normals[start:end], [], (bx, by, bw, bh), partial != 0,
                    area_px=area, centroid_px=None if math.isnan(u) else (u, v))
        stop = end
        splits = [end - start]
        for a, b in holes[h0 : h0 + n_h].tolist():
            blob.holes.append((outline[a:b], normals[a:b]))
            splits.append(splits[-1] + b - a)
            stop = b
        if rays is not None:
            blob.rays, blob.away = rays[start:stop], away[start:stop]
            blob.splits = np.array(splits)
        out.append(blob)
    return out


@njit(cache=True)
def joined_outlines(pts, starts, hier, picks, shifts, spans):  # pragma: no cover (compiled)
    """(areas, holes, outline, normals) of the contours ``picks`` (B,) with their holes:
    contour i is ``pts[starts[i]:starts[i + 1]]`` (int32 pixels, ``hier`` (n, 4) int32 as
    ``cv2.findContours`` gives it with ``RETR_CCOMP``), moved by ``shifts`` (B, 2), its
    holes its children of at least 6 points. ``outline``, ``normals`` (M, 2) float64 hold
    every picked contour and then its holes (:func:`cell.vision._blob._normals`); ``spans``
    (B, 4) int64 is filled with each one's outline rows [start, end), its first hole's row
    in ``holes`` (nh, 2: each hole's outline rows) and its hole count; ``areas`` (B, 3)
    its area (px^2: the outline's less the holes', as ``Geometry.area_mm2`` computes it)
    and pixel centroid (as :func:`~cell.vision._centroid.blob_centroid`; NaN where that
    leaves it to ``px_centroid``)."""
    nb = picks.shape[0]
    n_mem = n_holes = 0
    for b in range(nb):
        j = picks[b]
        n_mem += starts[j + 1] - starts[j]
        c = hier[j, 2]
        while c != -1:
            if starts[c + 1] - starts[c] >= 6:
                n_mem += starts[c + 1] - starts[c]
                n_holes += 1
            c = hier[c, 0]
    mem_pts = np.empty((n_mem, 2), np.int32)
    mem_meta = np.empty((nb + n_holes, 4), np.int64)
    holes = np.empty((n_holes, 2), np.int64)
    m = row = hole = 0
    for b in range(nb):
        j = picks[b]
        spans[b, 0], spans[b, 2] = row, hole
        c = j
        while c != -1:  # the outline, then its holes
            s, e = starts[c], starts[c + 1]
            if c == j or e - s >= 6:
                mem_pts[row : row + e - s] = pts[s:e]
                mem_meta[m, 0], mem_meta[m, 1] = e - s, c != j
                mem_meta[m, 2], mem_meta[m, 3] = shifts[b, 0], shifts[b, 1]
                if c != j:
                    holes[hole, 0], holes[hole, 1] = row, row + e - s
                    hole += 1
                m += 1
                row += e - s
            c = hier[c, 2] if c == j else hier[c, 0]
        spans[b, 1], spans[b, 3] = spans[b, 0] + starts[j + 1] - starts[j], hole - spans[b, 2]
    outline = np.empty((n_mem, 2))
    normals = np.empty((n_mem, 2))
    _normals(mem_pts, mem_meta, outline, normals)
    areas = np.empty((nb, 3))  # area; pixel centroid u, v (NaN: left to px_centroid)
    for b in range(nb):
        s, e, first, n_h = spans[b, 0], spans[b, 1], spans[b, 2], spans[b, 3]
        a = polygon_area(outline[s:e])  # (as Geometry.area_mm2 computes it)
        mm, cx, cy = _moments(outline, s, e)  # (as blob_centroid does)
        for i in range(first, first + n_h):
            a -= polygon_area(outline[holes[i, 0] : holes[i, 1]])
            m00, m10, m01 = _moments(outline, holes[i, 0], holes[i, 1])
            mm, cx, cy = mm - m00, cx - m10, cy - m01
        areas[b, 0] = a
        if abs(mm) < 1e-9:
            areas[b, 1] = areas[b, 2] = np.nan
        else:
            areas[b, 1], areas[b, 2] = cx / mm, cy / mm
    return areas, holes, outline, normals


@njit(cache=True)
def _window_blobs(pts, starts, hier, at, boxes, sub, margin, min_area2, h, w):  # pragma: no cover
    """(rows, windows, areas, holes, outline, normals, rois) of :func:`blobs_of_windows`:
    ``rows`` (B, 9) int64 per kept blob as :func:`joined_blobs` takes them; ``windows`` (B,
    2) its window and its roi's offset in ``rois``, the kept blobs' own pixels, each its
    window's shape, flattened one after the other; the rest as :func:`joined_outlines`
    gives them. ``pts`` (P, 2) int32 all contours one after another (contour j from
    ``starts[j]`` to ``starts[j + 1]``), ``hier`` (n, 4) int32, ``at`` (nw, 2) int64 the
    windows' mosaic corners (x increasing), ``boxes`` (nw, 4) int64 their frame boxes
    (x0, y0, x1, y1)."""
    n, nw = hier.shape[0], at.shape[0]
    win = np.full(n, -1, np.int64)  # each outer contour's window (by its first point)
    n_outer = np.zeros(nw, np.int64)
    for j in range(n):
        if hier[j, 3] == -1:
            x, k = pts[starts[j], 0], 0
            while k + 1 < nw and at[k + 1, 0] <= x:
                k += 1
            win[j] = k
            n_outer[k] += 1
    # the kept outer contours, window by window, each in the order traced
    kept = np.empty(n, np.int64)
    rows = np.empty((n, 9), np.int64)
    nk = 0
    for k in range(nw):
        if n_outer[k] == 0:
            continue
        for j in range(n):
            if win[j] != k or starts[j + 1] - starts[j] < 8:
                continue
            area, x0, y0, x1, y1 = area_box(pts, starts[j], starts[j + 1])
            if area < min_area2:
                continue  # a fragment (at least 3 px wide after the opening) far below a part
            kept[nk] = j
            sx, sy = boxes[k, 0] - at[k, 0], boxes[k, 1] - at[k, 1]  # mosaic to frame
            bx, by, bw, bh = x0 + sx, y0 + sy, x1 - x0 + 1, y1 - y0 + 1
            rows[nk, 0], rows[nk, 1], rows[nk, 2], rows[nk, 3] = bx, by, bw, bh
            rows[nk, 4] = bx <= margin or by <= margin or bx + bw >= w - margin or by + bh >= h - margin
            nk += 1
    kept, rows = kept[:nk], rows[:nk]
    shifts = np.empty((nk, 2), np.int64)
    windows = np.empty((nk, 2), np.int64)
    roi_size = 0
    for b in range(nk):
        k = win[kept[b]]
        shifts[b, 0], shifts[b, 1] = boxes[k, 0] - at[k, 0], boxes[k, 1] - at[k, 1]
        windows[b, 0], windows[b, 1] = k, roi_size
        roi_size += (boxes[k, 3] - boxes[k, 1]) * (boxes[k, 2] - boxes[k, 0])
    areas, holes, outline, normals = joined_outlines(pts, starts, hier, kept, shifts, rows[:, 5:])
    rois = np.empty(roi_size, np.uint8)
    grid = np.empty(0, np.uint8)
    todo = np.empty(0, np.int64)
    for b in range(nk):
        j, k, r0 = kept[b], windows[b, 0], windows[b, 1]
        x0, y0, x1, y1 = boxes[k, 0], boxes[k, 1], boxes[k, 2], boxes[k, 3]
        mx, my = at[k, 0], at[k, 1]
        wh, ww = y1 - y0, x1 - x0
        own = rois[r0 : r0 + wh * ww].reshape(wh, ww)
        window = sub[my : my + wh, mx : mx + ww]
        if n_outer[k] == 1:
            for r in range(wh):  # (row by row: numba's 2-d slice copy is slower)
                src, dst = window[r], own[r]
                for c in range(ww):
                    dst[c] = src[c]
        else:  # this part's pixels only, not a neighbour's
            if grid.shape[0] < (wh + 2) * (ww + 2):
                grid, todo = np.empty((wh + 2) * (ww + 2), np.uint8), np.empty(wh * ww, np.int64)
            _fill8(window, pts[starts[j], 1] - my, pts[starts[j], 0] - mx, own, grid, todo)
    return rows, windows, areas, holes, outline, normals, rois


@njit(cache=True)
def _fill8(src, y, x, out, grid, todo):  # pragma: no cover (compiled)
    """``out`` (``src``'s shape) 255 on the 8-connected region of nonzero pixels of
    ``src`` that holds (y, x), 0 elsewhere; ``grid`` (at least (h + 2) (w + 2)) and
    ``todo`` (at least h w) scratch. The region is grown on a copy framed by one empty
    pixel (0 empty, 1 to fill, 2 filled), so no neighbour needs a bounds test."""
    h, w = src.shape
    wp = w + 2
    size = (h + 2) * wp
    g = grid[:size]
    g[:wp] = 0
    g[size - wp :] = 0
    for r in range(h):
        row, cells = src[r], g[(r + 1) * wp : (r + 2) * wp]
        cells[0] = cells[w + 1] = 0
        for c in range(w):
            cells[c + 1] = row[c] != 0
    steps = (-wp - 1, -wp, -wp + 1, -1, 1, wp - 1, wp, wp + 1)
    start = (y + 1) * wp + x + 1
    g[start] = 2
    todo[0] = start
    top = 1
    while top:
        top -= 1
        p = todo[top]
        for d in steps:
            q = p + d
            if g[q] == 1:
                g[q] = 2
                todo[top] = q
                top += 1
    for r in range(h):
        cells, row = g[(r + 1) * wp + 1 : (r + 1) * wp + 1 + w], out[r]
        for c in range(w):
            row[c] = 255 * (cells[c] >> 1)
