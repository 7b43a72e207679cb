"""Material of every part in a frame at once, from each part's own pixels.

Per part: the interior, away from the edge's blend with the belt (a 5x5 erosion of its
mask ``Blob.roi``, or 3x3 where that leaves fewer than 150 pixels: a square nut's ring is
4 px wide), and the belt's colour next to it, which white-balances its albedo (a part
seen against a glowing light table is a silhouette: ``unknown``). One compiled pass
(:func:`cell.vision._material_kernel.frame_statistics`) measures every part; the features
(:func:`cell.vision.material.features_from_statistics`) and labels
(:func:`cell.vision.material.classify_materials`) follow for all parts at once.
"""

from __future__ import annotations

import numpy as np

from cell.vision._blob import Blob
from cell.vision._material_kernel import N, frame_statistics, noise_sigma
from cell.vision._segment import FrameView
from cell.vision.material import classify_materials, features_from_statistics

__all__: list[str] = []  # private to cell.vision

_UNKNOWN = ("unknown", 0.0)


def part_materials(view: FrameView, blobs: list[Blob]) -> list[tuple[str, float]]:
    """(material, confidence) of each blob, from its ROI's interior (see the module
    docstring); ``unknown`` for a back-lit frame, a blob without ROI, an interior under 8
    pixels, or a part on a light table."""
    out = [_UNKNOWN] * len(blobs)
    if view.backlit:
        return out
    have = [i for i, b in enumerate(blobs) if b.roi is not None]
    if not have:
        return out
    rois = [blobs[i].roi for i in have]
    sizes = [r[2].size for r in rois]
    boxes = np.empty((len(rois), 5), np.int64)
    boxes[:, :2] = [r[:2] for r in rois]
    boxes[:, 2:4] = [r[2].shape for r in rois]
    boxes[:, 4] = np.cumsum([0, *sizes[:-1]])
    masks = np.concatenate([r[2].reshape(-1) for r in rois])
    stats, belts = frame_statistics(view.img, view.fg, boxes, masks)
    st = view.settings
    found = []
    for j, (i, (free, *belt)) in enumerate(zip(have, belts.tolist(), strict=True)):
        if stats[j, N] == 0:
            continue  # an interior under 8 pixels
        if free < 30:  # hardly any belt around: its estimate at the part's centre
            x0, y0, roi = rois[j]
            h, w = view.fg.shape
            u, v = min(x0 + roi.shape[1] // 2, w - 1), min(y0 + roi.shape[0] // 2, h - 1)
            belt = view.background_at(u, v, u + 1, v + 1)[0, 0].tolist()
            belts[j, 1:] = belt
        if min(belt) >= st.backlight_level:
            continue  # a glowing light table behind this part: a silhouette
        found.append((i, j))
    if not found:
        return out
    rows = [j for _, j in found]
    feats = features_from_statistics(stats[rows], belts[rows, 1:], belt_rgb=st.belt_rgb,
                                     noise_sigma=noise_sigma(view.img))
    labels = classify_materials(feats, backlit=False, grain_metal=st.grain_metal,
                                grain_z_min=st.grain_z_min, albedo_sigma=st.albedo_sigma)
    for (i, _), label in zip(found, labels, strict=True):
        out[i] = label
    return out
