"""Scoring a frame's detections against the scene's ground truth (never used to decide).

A detection is matched to the part whose segmentation covers most of a small window
around its pixel centroid (the window grows from 7 to 31 px: a washer's centroid lies in
its hole); a detection on no part, or on a part already matched, is false. A part counts
when it is fully in view (not on the image border) and at least ``MIN_PIXELS`` large;
a detection flagged ``partial`` is not scored for kind, material or pose.

:func:`foreground_iou` scores a foreground mask against the segmentation inside the
belt's band (outside it lie the table and the rails, which the detector's later steps
take out as no parts).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cell.catalogue import KINDS
from cell.sweep.scene import Scene, belt_rows

__all__ = ["MIN_PIXELS", "FrameScore", "figures", "foreground_iou", "part_at", "score_frame"]

MIN_PIXELS = 30


@dataclass(frozen=True)
class FrameScore:
    """How a frame's detections match its parts: ``parts`` fully in view, ``found`` of them
    matched by a (non-partial) detection, ``false`` detections, ``kind_ok``,
    ``material_ok``, ``material_unknown`` and ``class_ok`` (kind and material both right)
    among the found, their ``position_errors_mm``
    and ``yaw_errors_deg`` (yaw modulo the kind's symmetry, when the kind is right and
    has an orientation)."""

    parts: int
    found: int
    false: int
    kind_ok: int
    material_ok: int
    material_unknown: int
    class_ok: int
    position_errors_mm: tuple[float, ...]
    yaw_errors_deg: tuple[float, ...]


def part_at(seg: np.ndarray, centroid: tuple[float, float]) -> int:
    """The part id (0: none) most common among ``seg``'s non-zero pixels (int (H, W), part
    ids) in a window 3 px either side of ``centroid`` (u, v, px), grown by 4 px up to 15
    px either side while it holds no part (a washer's centroid lies in its hole)."""
    u, v = int(round(centroid[0])), int(round(centroid[1]))
    for r in (3, 7, 11, 15):
        win = seg[max(v - r, 0): v + r + 1, max(u - r, 0): u + r + 1]
        ids = win[win > 0]
        if ids.size:
            return int(np.bincount(ids).argmax())
    return 0


def score_frame(scene: Scene, detections: list) -> FrameScore:
    """Match ``detections`` (``Detection``-like objects) to ``scene``'s parts."""
    seg = scene.seg
    ids, counts = np.unique(seg[seg > 0], return_counts=True)
    border = set(np.unique(np.concatenate([seg[0], seg[-1], seg[:, 0], seg[:, -1]])).tolist())
    inside = {int(i) for i, c in zip(ids, counts, strict=True) if c >= MIN_PIXELS and i not in border}
    truth = {p.id: p for p in scene.parts}
    matched: dict[int, object] = {}
    false = 0
    for d in detections:
        pid = part_at(seg, d.centroid)
        if pid == 0 or pid in matched:
            false += 1
        else:
            matched[pid] = d
    found = kind_ok = material_ok = unknown = class_ok = 0
    pos, yaw = [], []
    for pid in sorted(inside):
        d = matched.get(pid)
        if d is None or d.partial or pid not in truth:
            continue
        t = truth[pid]
        found += 1
        kind_ok += d.kind == t.kind
        material_ok += d.material == t.material
        unknown += d.material == "unknown"
        class_ok += d.kind == t.kind and d.material == t.material
        if d.position is not None:
            pos.append(1e3 * math.hypot(d.position[0] - t.position[0], d.position[1] - t.position[1]))
        e = KINDS[t.kind].yaw_error(d.yaw, t.yaw) if d.kind == t.kind else None
        if e is not None:
            yaw.append(math.degrees(e))
    return FrameScore(len(inside), found, false, kind_ok, material_ok, unknown, class_ok, tuple(pos),
                      tuple(yaw))


def _share(n: int, d: int) -> float | None:
    return n / d if d else None


def _stat(values: tuple[float, ...], fn) -> float | None:
    return float(fn(values)) if values else None


def figures(score: FrameScore) -> dict[str, float | int | None]:
    """The detect job's figures of one frame (a figure with no samples is None)."""
    return {
        "parts": score.parts,
        "found": score.found,
        "recall": _share(score.found, score.parts),
        "false_detections": score.false,
        "kind_accuracy": _share(score.kind_ok, score.found),
        "material_accuracy": _share(score.material_ok, score.found),
        "material_unknown": _share(score.material_unknown, score.found),
        "classification_accuracy": _share(score.class_ok, score.found),
        "position_error_mm_mean": _stat(score.position_errors_mm, np.mean),
        "position_error_mm_max": _stat(score.position_errors_mm, np.max),
        "yaw_error_deg_max": _stat(score.yaw_errors_deg, np.max),
    }


def foreground_iou(mask: np.ndarray, scene: Scene) -> float | None:
    """Intersection over union of ``mask`` (bool or uint8 (H, W), nonzero = foreground)
    with the parts' pixels, inside the belt's band; None when both are empty there."""
    first, last = belt_rows(scene.camera)
    fg = np.asarray(mask)[first: last + 1] > 0
    truth = scene.seg[first: last + 1] > 0
    union = int(np.count_nonzero(fg | truth))
    return int(np.count_nonzero(fg & truth)) / union if union else None
