"""Scoring ``cell bench vision``: detections matched to the simulator's parts through the
segmentation image, and the per-preset figures. Ground truth is read here only.

A detection belongs to the part most of the segmentation pixels around its centroid show
(a window 3 px either side, grown to 15 px either side where the centroid falls in a hole); a second detection
of one part, or one on the background, is false. A part with at least 30 visible pixels
that no detection matched is missed, unless it touches the image border (partial).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from cell.catalogue import KINDS
from cell.sweep.scoring import part_at
from cell.vision.detector import StepTimes

__all__ = ["REQUIRED", "STEPS", "Tally", "failures", "score_frame", "summarise"]

STEPS = tuple(f.name for f in fields(StepTimes))  # the detector's steps, as timed
REQUIRED = {"material": 0.995, "kind": 0.99, "pos_p95_mm": 1.0, "yaw_p95_deg": 2.0,
            "latency_ms": 5.0, "latency_over_render": 0.5, "cold_s": 5.0}


@dataclass
class Tally:
    """One preset's running tallies: counts of parts (``n`` scored), of material and kind
    outcomes, false and missed detections, partial parts told right or wrong and touching
    pairs split; errors (``pos_err`` m, ``yaw_err`` rad); times (s: ``latency`` per frame,
    ``again`` for a repeat, ``render``, ``per_part``) and the detector's ``steps``; the
    kinds of mistakes (``material_errors``, ``kind_errors``: "truth->detected")."""

    n: int = 0
    material_ok: int = 0
    material_wrong: int = 0
    material_unknown: int = 0
    kind_ok: int = 0
    false: int = 0
    missed: int = 0
    partial_ok: int = 0
    partial_wrong: int = 0
    touching_pairs: int = 0
    touching_split: int = 0
    pos_err: list[float] = field(default_factory=list)
    yaw_err: list[float] = field(default_factory=list)
    latency: list[float] = field(default_factory=list)
    again: list[float] = field(default_factory=list)
    render: list[float] = field(default_factory=list)
    steps: list[StepTimes] = field(default_factory=list)
    per_part: list[float] = field(default_factory=list)
    material_errors: list[str] = field(default_factory=list)
    kind_errors: list[str] = field(default_factory=list)


def _touching_pairs(seg: np.ndarray) -> set[tuple[int, int]]:
    pairs = set()
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = seg[max(dy, 0):, max(dx, 0): seg.shape[1] + min(dx, 0)]
        b = seg[: seg.shape[0] - dy, max(-dx, 0): seg.shape[1] - max(dx, 0)]
        m = (a > 0) & (b > 0) & (a != b)
        for i, j in zip(a[m].tolist(), b[m].tolist(), strict=True):
            pairs.add((min(i, j), max(i, j)))
    return pairs


def score_frame(world, frame_seg: np.ndarray, dets: list, stats: Tally) -> None:
    """Add one frame's detections ``dets`` to a preset's ``stats`` (a :class:`Tally`),
    matched to the parts through the segmentation image ``frame_seg`` (int (H, W), part
    ids, 0 the background) and scored against ``world``'s ground truth."""
    seg = frame_seg
    h, w = seg.shape
    ids, counts = np.unique(seg[seg > 0], return_counts=True)
    border = set(np.unique(np.concatenate([seg[0], seg[-1], seg[:, 0], seg[:, -1]])).tolist())
    visible = {int(i) for i, c in zip(ids, counts, strict=True) if c >= 30}
    matched: dict[int, object] = {}
    for d in dets:
        pid = part_at(seg, d.centroid)
        if pid == 0 or pid in matched:
            stats.false += 1
            continue
        matched[pid] = d
    for pid in visible:
        info = world.parts[pid - 1]
        if pid not in matched:
            if pid not in border:
                stats.missed += 1
            continue
        d = matched[pid]
        if pid in border or d.partial:
            if (pid in border) == d.partial:
                stats.partial_ok += 1
            else:
                stats.partial_wrong += 1
            continue
        stats.n += 1
        stats.kind_ok += d.kind == info.kind
        if d.material == "unknown":
            stats.material_unknown += 1
        elif d.material == info.material:
            stats.material_ok += 1
        else:
            stats.material_wrong += 1
            stats.material_errors.append(f"{info.finish}->{d.material}")
        if d.kind != info.kind:
            stats.kind_errors.append(f"{info.kind}->{d.kind}")
        pos, _ = world.part_pose(pid)
        if d.position is not None:
            stats.pos_err.append(math.hypot(d.position[0] - pos[0], d.position[1] - pos[1]))
        e = KINDS[info.kind].yaw_error(d.yaw, world.part_yaw(pid)) if d.kind == info.kind else None
        if e is not None:
            stats.yaw_err.append(e)
    pairs = [p for p in _touching_pairs(seg) if p[0] not in border and p[1] not in border]
    stats.touching_pairs += len(pairs)
    stats.touching_split += sum(1 for a, b in pairs if a in matched and b in matched)


def _pct(values, q: float, scale: float = 1.0) -> float | None:
    """The ``q``-th percentile of ``values`` times ``scale``; ``None`` if there are none."""
    return float(np.percentile(values, q)) * scale if len(values) else None


def summarise(stats: dict[str, Tally], scenes: int, seed_base: int, parts: int) -> dict:
    """The bench's report from each preset's ``stats``: accuracies, error percentiles
    (mm, degrees), counts and latencies (ms); a figure with no samples is None."""
    rows = {}
    for preset, s in stats.items():
        n = max(s.n, 1)
        pos = np.array(s.pos_err) * 1e3
        yaw = np.degrees(np.array(s.yaw_err))
        lat = _pct(s.latency, 50, 1e3)
        ren = _pct(s.render, 50, 1e3)
        rows[preset] = {
            "parts": s.n,
            "material_accuracy": s.material_ok / n if s.n else None,
            "material_wrong": s.material_wrong,
            "material_unknown": s.material_unknown,
            "kind_accuracy": s.kind_ok / n if s.n else None,
            "position_p50_mm": _pct(pos, 50),
            "position_p95_mm": _pct(pos, 95),
            "yaw_p95_deg": _pct(yaw, 95),
            "false": s.false,
            "missed": s.missed,
            "recall": s.n / max(s.n + s.missed, 1),
            "partial_ok": s.partial_ok,
            "partial_wrong": s.partial_wrong,
            "touching_pairs": s.touching_pairs,
            "touching_split": s.touching_split,
            "latency_ms": lat,
            "latency_p95_ms": _pct(s.latency, 95, 1e3),
            "latency_per_part_ms": _pct(s.per_part, 50, 1e3),
            "repeat_latency_ms": _pct(s.again, 50, 1e3),
            "render_ms": ren,
            "latency_over_render": lat / ren if lat is not None and ren else None,
            "step_ms": {name: _pct([getattr(t, name) for t in s.steps], 50, 1e3)
                        for name in STEPS},
            "material_errors": sorted(set(s.material_errors))[:10],
            "kind_errors": sorted(set(s.kind_errors))[:10],
        }
    out = {"scenes_per_preset": scenes, "parts_per_scene": parts,
           "seed_base": seed_base, "required": REQUIRED, "presets": rows}
    out["failures"] = failures(out)
    out["meets_required"] = not out["failures"]
    return out


_BARS = (("kind_accuracy", "kind", "<"), ("position_p95_mm", "pos_p95_mm", ">"),
         ("yaw_p95_deg", "yaw_p95_deg", ">"), ("latency_ms", "latency_ms", ">"),
         ("latency_over_render", "latency_over_render", ">"))


def failures(report: dict) -> list[str]:
    """The must-reach bars (``REQUIRED``) a report misses, one line each ("dim
    latency_ms 12.3 > 5"): per preset material (``back``: none wrong; it may be unknown),
    kind, position and yaw p95, latency and its ratio to the render; the cold start when
    the report has one. A figure with no samples misses its bar ("no figure")."""
    out = []
    for preset, r in report["presets"].items():
        bars = _BARS if preset == "back" else (("material_accuracy", "material", "<"), *_BARS)
        for key, bar, worse in bars:
            value, limit = r[key], REQUIRED[bar]
            if value is None:
                out.append(f"{preset} {key}: no figure")
            elif (value < limit) if worse == "<" else (value > limit):
                out.append(f"{preset} {key} {value:.4g} {worse} {limit:g}")
        if preset == "back" and r["material_wrong"]:
            out.append(f"back material_wrong {r['material_wrong']} > 0")
    cold = report.get("cold")
    if cold is not None and cold["first_detection_s"] > REQUIRED["cold_s"]:
        out.append(f"cold first_detection_s {cold['first_detection_s']:.3g} > {REQUIRED['cold_s']:g}")
    return out
