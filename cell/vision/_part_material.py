"""Material of every part in a frame at once, from each part's own pixels.

Per part: the interior, away from the edge's blend with the belt (a 5x5 erosion of its
mask ``Blob.roi``, or 3x3 where that leaves fewer than 150 pixels: a square nut's ring is
4 px wide), and the belt's colour next to it, which white-balances its albedo (a part
seen against a glowing light table is a silhouette: ``unknown``). One compiled pass
(:func:`cell.vision._material_kernel.frame_statistics`) measures every part; the features
and labels (:func:`cell.vision.material.materials_from_statistics`) follow for all
parts at once.
"""

from __future__ import annotations

import numpy as np

from cell.vision._blob import Blob
from cell.vision._material_kernel import MEASURED, NO_BELT, frame_statistics, noise_sigma
from cell.vision._segment import FrameView
from cell.vision.material import materials_from_statistics

__all__: list[str] = []  # private to cell.vision

_UNKNOWN = ("unknown", 0.0)


def part_materials(view: FrameView, blobs: list[Blob]) -> list[tuple[str, float]]:
    """(material, confidence) of each blob, from its ROI's interior (see the module
    docstring); ``unknown`` for a back-lit frame, a blob without ROI, an interior under 8
    pixels, or a part on a light table."""
    out = [_UNKNOWN] * len(blobs)
    if view.backlit:
        return out
    have = [(i, b.roi) for i, b in enumerate(blobs) if b.roi is not None]
    if not have:
        return out
    boxes = np.array([(x0, y0, *m.shape) for _, (x0, y0, m) in have], np.int64)
    masks = np.concatenate([m.reshape(-1) for _, (_, _, m) in have])
    st = view.settings
    stats, belts, state = frame_statistics(view.img, view.fg, boxes, masks, st.backlight_level)
    states = state.tolist()
    for j in [j for j, s in enumerate(states) if s == NO_BELT]:  # hardly any belt around:
        x0, y0, m = have[j][1]  # its estimate at the part's centre
        u = min(x0 + m.shape[1] // 2, view.fg.shape[1] - 1)
        v = min(y0 + m.shape[0] // 2, view.fg.shape[0] - 1)
        belts[j, 1:] = view.background_at(u, v, u + 1, v + 1)[0, 0]
        states[j] = MEASURED if min(belts[j, 1:].tolist()) < st.backlight_level else 0
    rows = [j for j, s in enumerate(states) if s == MEASURED]
    if not rows:
        return out
    if len(rows) < len(states):
        stats, belts = stats[rows], belts[rows]
    labels = materials_from_statistics(
        stats, belts[:, 1:], belt_rgb=st.belt_rgb, noise_sigma=noise_sigma(view.img),
        grain_metal=st.grain_metal, grain_z_min=st.grain_z_min, albedo_sigma=st.albedo_sigma)
    for j, label in zip(rows, labels, strict=True):
        out[have[j][0]] = label
    return out
