"""Scoring of a sort run against the simulator's ground truth: the report's rows, metrics
and accounting.

This is the one module of the sort job that reads ground truth, and it only scores: the
job hands it each pick as it starts (``Scorekeeper.attach``: which true part lay nearest
the detection when the image was taken, and how far off the detection was), and at the
end where every spawned part came to rest decides its outcome:

- in the bin of its material: ``binned_correct``; in the other material's bin:
  ``binned_wrong``; in the reject bin: ``rejected``;
- fallen off the belt's end into the catch bin, or still on the belt: ``missed``;
- anywhere else (the table, the floor, a bin's rim): ``dropped``.

So ``spawned = binned + rejected + missed + dropped`` holds by construction, and the
accounting checks it; ``parts = spawned + not_spawned`` (the feeder's parts the job ended
before). ``sort_accuracy`` is parts in their correct bin over the run's parts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from cell.catalogue import KINDS

COMPLETED = "every part came through"  # a report's ``ended`` when the job did not end early

__all__ = ["COMPLETED", "OUTCOMES", "PickRecord", "Scorekeeper", "metrics_of"]

OUTCOMES = ("binned_correct", "binned_wrong", "rejected", "missed", "dropped")


@dataclass
class PickRecord:
    """One pick as the job saw it: when the image was taken (``t``, s), the detection it
    acted on (a JSON-ready dict), the bin it chose, what happened (``placed``,
    ``grasp_failed``, ``lost``, ``unreachable``, ``blocked``), the cycle time (s) of a
    placed one, whether the next look found the spot empty (``verified``), and the
    lighting preset of a second look that decided the material (``second_look``)."""

    index: int
    t: float
    detection: dict
    bin: str
    result: str = "pending"
    cycle_time: float | None = None
    verified: bool | None = None
    message: str = ""
    encoder: float = 0.0  # m: the belt's encoder when the image was taken
    second_look: str = ""  # the preset whose look decided the material, if one did


@dataclass
class _Match:
    part_id: int
    position_error_mm: float
    yaw_error_deg: float | None


@dataclass
class Scorekeeper:
    """Ground truth, for scoring only: matches picks to true parts and scores the run."""

    world: object
    matches: dict[int, _Match] = field(default_factory=dict)

    def attach(self, record: PickRecord, det: object) -> None:
        """Note which true part lies nearest ``det`` (the detection ``record`` acts on) now,
        at the time of its image, and the detection's position and yaw errors."""
        if det.position is None or not self.world.on_stage:
            return
        parts = self.world.on_stage
        gaps = [float(np.hypot(*(_true_xy(self.world, p.id) - det.position))) for p in parts]
        part = parts[int(np.argmin(gaps))]
        self.matches[record.index] = _Match(part.id, 1000.0 * min(gaps),
                                            _yaw_error(det, part.kind, self.world.part_yaw(part.id)))

    def rows(self, records: list[PickRecord]) -> list[dict]:
        """One row per spawned part: its truth, the last detection acted on, the bin
        chosen, the attempts, its outcome and errors, the cycle time of its placing."""
        by_part: dict[int, list[PickRecord]] = {}
        for r in records:
            if r.index in self.matches:
                by_part.setdefault(self.matches[r.index].part_id, []).append(r)
        out = []
        for part in self.world.parts[: self.world.spawned]:
            mine = by_part.get(part.id, [])
            last = mine[-1] if mine else None
            match = self.matches[last.index] if last else None
            place = self.world.place_of(part.id)
            placed = [r for r in mine if r.result == "placed"]
            out.append({
                "id": part.id,
                "truth": {"kind": part.kind, "material": part.material, "finish": part.finish,
                          "flipped": self.world.faults.is_flipped(part.id)},
                "detection": last.detection if last else None,
                "bin": last.bin if last else None,
                "attempts": len(mine),
                "ended_in": place,
                "outcome": _outcome(place, part.material),
                "position_error_mm": match.position_error_mm if match else None,
                "yaw_error_deg": match.yaw_error_deg if match else None,
                "cycle_time_s": placed[-1].cycle_time if placed else None,
            })
        return out


def _outcome(place: str, material: str) -> str:
    if place in ("metal", "plastic"):
        return "binned_correct" if place == material else "binned_wrong"
    if place == "reject":
        return "rejected"
    return "missed" if place in ("caught", "belt") else "dropped"


def _yaw_error(det: object, kind: str, true_yaw: float) -> float | None:
    """The yaw error (deg) modulo the true kind's symmetry; None for a round part or a
    detection of another kind."""
    err = KINDS[kind].yaw_error(det.yaw, true_yaw) if det.kind == kind else None
    return None if err is None else math.degrees(err)


def _quantile(values: list[float], q: float) -> float | None:
    return float(np.quantile(values, q)) if values else None


def _true_xy(world: object, part_id: int) -> np.ndarray:
    """GROUND TRUTH (scoring): the part's (x, y) on the table (m)."""
    position, _ = world.part_pose(part_id)
    return position[:2]


def metrics_of(rows: list[dict], records: list[PickRecord], *, parts: int, sim_time: float,
               wall_time: float) -> tuple[dict, dict]:
    """The report's ``metrics`` and ``accounting`` from the part rows (one per spawned
    part), the picks and the run's number of ``parts``: those the feeder never put out
    (the job ended first) are ``not_spawned``, and count against ``sort_accuracy``.

    A figure with no samples is None (``null`` in JSON), never NaN."""
    counts = {k: sum(r["outcome"] == k for r in rows) for k in OUTCOMES}
    spawned = len(rows)
    accounting = {"parts": parts, "not_spawned": parts - spawned,
                  "spawned": spawned, "binned": counts["binned_correct"] + counts["binned_wrong"],
                  "binned_correct": counts["binned_correct"], "binned_wrong": counts["binned_wrong"],
                  "rejected": counts["rejected"], "missed": counts["missed"],
                  "dropped": counts["dropped"]}
    seen = [r for r in rows if r["detection"] is not None]
    right = [r for r in seen if r["detection"]["kind"] == r["truth"]["kind"]
             and r["detection"]["material"] == r["truth"]["material"]]
    errors = [r["position_error_mm"] for r in seen if r["position_error_mm"] is not None]
    yaws = [r["yaw_error_deg"] for r in seen if r["yaw_error_deg"] is not None]
    placed = [p for p in records if p.result == "placed"]
    cycles = [p.cycle_time for p in placed if p.cycle_time is not None]
    metrics = {
        "sort_accuracy": counts["binned_correct"] / parts if parts else None,
        "classification_accuracy": len(right) / len(seen) if seen else None,
        "pick_success": len(placed) / len(records) if records else None,
        "position_error_mm_p50": _quantile(errors, 0.5),
        "position_error_mm_p95": _quantile(errors, 0.95),
        "yaw_error_deg_p50": _quantile(yaws, 0.5),
        "yaw_error_deg_p95": _quantile(yaws, 0.95),
        "cycle_time_s_mean": float(np.mean(cycles)) if cycles else None,
        "parts_per_minute": 60.0 * len(placed) / sim_time if sim_time > 0 else None,
        "sim_time_s": sim_time,
        "wall_time_s": wall_time,
        "real_time_factor": sim_time / wall_time if wall_time > 0 else None,
    }
    return metrics, accounting
