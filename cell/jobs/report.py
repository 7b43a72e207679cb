"""What a sort run shows a user: the summary table, and the last capture with its detections.

``summary_table(report)`` is the text ``cell run`` prints; ``draw_detections(image,
detections)`` draws each detection's outline box, centre and label (``id kind material``,
green for a part sorted to its material's bin, orange for one rejected) onto a copy of
the image; ``encode_png`` turns it into the bytes of ``detections.png``.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from cell.benchmarks import fmt
from cell.errors import JobError
from cell.jobs.score import COMPLETED, OUTCOMES
from cell.sim.layout import BELT_TOP
from cell.text import escape

__all__ = ["draw_detections", "encode_png", "summary_table"]

_SURE = (40, 200, 60)  # RGB of a part sorted by material
_REJECT = (255, 150, 0)  # RGB of a part sent to the reject bin, or partial


def summary_table(report: dict) -> str:
    """The summary of a sort ``report``: the accounting, the metrics, where the wall time went."""
    m, a = report["metrics"], report["accounting"]
    lines = [f"sort job: scenario {escape(report['scenario'])}, seed {report['seed']}, "
             f"{report['mode']} mode, detector {escape(report['detector'])}, "
             f"captures {'+'.join(report['capture_presets'])}", ""]
    lines.append(f"{'parts':<16} {a['parts']:>5}")
    for key in OUTCOMES:
        lines.append(f"  {key:<14} {sum(r['outcome'] == key for r in report['parts']):>5}")
    if a["not_spawned"]:
        lines.append(f"  {'not_spawned':<14} {a['not_spawned']:>5}")
    if report["ended"] != COMPLETED:
        lines += ["", f"the job ended early: {report['ended']}"]
    lines += ["", f"{'sort accuracy':<24} {_pct(m['sort_accuracy'])}",
              f"{'classification accuracy':<24} {_pct(m['classification_accuracy'])}",
              f"{'pick success':<24} {_pct(m['pick_success'])}",
              f"{'position error p50/p95':<24} {fmt(m['position_error_mm_p50'], '.3f')} / "
              f"{fmt(m['position_error_mm_p95'], '.3f')} mm",
              f"{'yaw error p50/p95':<24} {fmt(m['yaw_error_deg_p50'], '.2f')} / "
              f"{fmt(m['yaw_error_deg_p95'], '.2f')} deg",
              f"{'cycle time mean':<24} {fmt(m['cycle_time_s_mean'], '.2f')} s",
              f"{'parts per minute':<24} {fmt(m['parts_per_minute'], '.1f')} (simulated)",
              f"{'simulated / wall time':<24} {m['sim_time_s']:.1f} s / {m['wall_time_s']:.1f} s "
              f"(real-time factor {fmt(m['real_time_factor'], '.1f')})"]
    spent = ", ".join(f"{k} {100 * v:.0f} %" for k, v in report["wall_time_fractions"].items()
                      if v is not None)
    lines.append(f"{'wall time went to':<24} {spent}")
    return "\n".join(lines)


def _pct(value: float | None) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{100 * value:.1f} %"


def draw_detections(image: np.ndarray, detections: list, *, camera: object,
                    bins: list[str] | None = None) -> np.ndarray:
    """A copy of ``image`` (uint8 RGB (H, W, 3)) with each detection's box (its footprint
    size turned into pixels at its centroid, along its yaw), centre and label drawn;
    ``camera`` (the ``CameraModel``, looking down on the belt) gives the scale, ``bins``
    (one per detection) colours a rejected one orange."""
    _check_rgb("draw_detections", image)
    out = np.ascontiguousarray(image.copy())
    h = out.shape[0]
    px = camera.K[0, 0] / max(1e-3, camera.T_world_camera[2, 3] - BELT_TOP)  # px per m
    scale = max(1, round(h / 480))
    big = 4.0 * max(out.shape[:2])  # px: a box no larger than this is drawn (a detector may say 1 km)
    for k, d in enumerate(detections):
        colour = _REJECT if d.partial or (bins and bins[k] == "reject") else _SURE
        u, v = d.centroid
        size = (min(d.size[0] * px, big), min(d.size[1] * px, big))
        rect = ((float(u), float(v)), size, -math.degrees(d.yaw % (2 * math.pi)))
        box = cv2.boxPoints(rect).astype(np.int32)
        cv2.polylines(out, [box], True, colour, scale, cv2.LINE_AA)
        cv2.circle(out, (round(u), round(v)), 2 * scale, colour, -1, cv2.LINE_AA)
        label = f"{d.id} {d.kind} {d.material}"
        org = (max(0, round(u) - 30 * scale), max(12 * scale, round(v) - 14 * scale))
        cv2.putText(out, label, org, cv2.FONT_HERSHEY_SIMPLEX, 0.4 * scale, (0, 0, 0), 3 * scale,
                    cv2.LINE_AA)
        cv2.putText(out, label, org, cv2.FONT_HERSHEY_SIMPLEX, 0.4 * scale, colour, scale, cv2.LINE_AA)
    return out


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of a uint8 RGB (H, W, 3) image."""
    _check_rgb("encode_png", image)
    ok, buf = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    if not ok:
        raise JobError("detections.png: OpenCV could not encode the image as PNG")
    return buf.tobytes()


def _check_rgb(where: str, image: object) -> None:
    """A JobError naming ``where`` unless ``image`` is a uint8 RGB array (H, W, 3)."""
    if (not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3
            or image.shape[2] != 3 or 0 in image.shape):
        got = (f"{image.dtype} {image.shape}" if isinstance(image, np.ndarray)
               else type(image).__name__)
        raise JobError(f"{where}: argument 'image': expected a uint8 RGB array (H, W, 3), got {got}")
