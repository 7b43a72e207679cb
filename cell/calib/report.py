"""The calibration report: errors against the simulator's ground truth, as JSON and a table.

Ground truth enters here only, to score: the camera's true intrinsics and distortion and
its true mount on the flange (:class:`WristTruth`, read from the simulator by the job),
and where the touch test's points truly are. Signed errors are estimate minus truth;
relative errors are that over the truth (``k1_rel_err`` is null when the true k1 is 0).
Every number is finite: the JSON is strict (no NaN).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cell.calib.touch import TouchResult
from cell.calib.transforms import pose_error
from cell.calib.wrist import WristCalibration

__all__ = ["WristTruth", "format_wrist", "score_wrist"]


@dataclass(frozen=True, eq=False)
class WristTruth:
    """GROUND TRUTH of the wrist camera (from the simulator): ``K`` (3x3, px), ``dist``
    (5,), ``T_flange_camera`` (4x4, m)."""

    K: np.ndarray
    dist: np.ndarray
    T_flange_camera: np.ndarray


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _pose_entry(T_est: np.ndarray, truth: WristTruth, consistency: float) -> dict:
    rot, trans = pose_error(T_est, truth.T_flange_camera)
    return {"rot_err_deg": rot, "trans_err_mm": 1000.0 * trans, "consistency_px": _finite(consistency)}


def score_wrist(result: WristCalibration, truth: WristTruth, touch: TouchResult | None) -> dict:
    """The report of one wrist calibration (a JSON-ready dict; see the module docstring)."""
    K, Kt = result.intrinsics.K, truth.K
    k1, k1t = float(result.intrinsics.dist[0]), float(truth.dist[0])
    intrinsics = {
        "fx_rel_err": K[0, 0] / Kt[0, 0] - 1.0, "fy_rel_err": K[1, 1] / Kt[1, 1] - 1.0,
        "cx_err_px": K[0, 2] - Kt[0, 2], "cy_err_px": K[1, 2] - Kt[1, 2],
        "k1_rel_err": None if k1t == 0 else k1 / k1t - 1.0, "k1": k1, "k1_true": k1t,
        "reproj_rms_px": result.intrinsics.rms,
        "view_rms_px": [float(v) for v in result.intrinsics.view_rms],
        "views_used": len(result.used), "views_rejected": result.rejected,
    }
    hand_eye: dict = {e.method: _pose_entry(e.T_flange_camera, truth, e.consistency_px)
                      for e in result.hand_eye}
    hand_eye["refined"] = _pose_entry(result.refinement.T_flange_camera, truth, result.refinement.rms_px)
    hand_eye["chosen"] = result.chosen
    hand_eye["kept"] = result.kept
    hand_eye["chain_to_pixel_rms"] = result.refinement.rms_px / result.intrinsics.rms
    capture = result.capture
    out = {
        "intrinsics": {k: (float(v) if isinstance(v, float | np.floating) else v)
                       for k, v in intrinsics.items()},
        "hand_eye": hand_eye,
        "touch_err_mm": None if touch is None else float(touch.errors_mm.max()),
        "touch": None if touch is None else {
            "corners": list(touch.corner_ids), "errors_mm": [float(e) for e in touch.errors_mm]},
        "capture": {"views": len(capture.views), "unreachable": capture.unreachable,
                    "blocked": capture.blocked,
                    "detectors": [d.detector if d is not None else None for d in result.detections]},
    }
    return out


def _pct(x: float) -> str:
    return f"{100 * x:+.4f} %"


def format_wrist(report: dict) -> str:
    """The wrist camera's report as a table (text)."""
    i, h = report["intrinsics"], report["hand_eye"]
    c = report["capture"]
    lines = [
        f"wrist camera: {i['views_used']} views used, {i['views_rejected']} without the board, "
        f"{c['unreachable']} poses unreachable, {c['blocked']} too near the cell",
        "",
        "intrinsics (estimate - truth)",
        f"  fx {_pct(i['fx_rel_err'])}   fy {_pct(i['fy_rel_err'])}   cx {i['cx_err_px']:+.3f} px   "
        f"cy {i['cy_err_px']:+.3f} px",
        f"  k1 {i['k1']:+.5f} (true {i['k1_true']:+.5f}"
        + ("" if i["k1_rel_err"] is None else f", {_pct(i['k1_rel_err'])}") + ")",
        f"  reprojection RMS {i['reproj_rms_px']:.4f} px (views {min(i['view_rms_px']):.3f}"
        f"..{max(i['view_rms_px']):.3f})",
        "",
        f"hand-eye T_flange_camera     {'rot (deg)':>10} {'trans (mm)':>11} {'consistency (px)':>17}",
    ]
    for name, e in h.items():
        if isinstance(e, dict):
            mark = " <- chosen" if name == h["chosen"] else (" <- kept" if name == h["kept"] else "")
            cons = "-" if e["consistency_px"] is None else f"{e['consistency_px']:.4f}"
            lines.append(f"  {name:<26} {e['rot_err_deg']:>10.4f} {e['trans_err_mm']:>11.3f} "
                         f"{cons:>17}{mark}")
    ratio = h["chain_to_pixel_rms"]
    if h["kept"] == "refined":
        lines.append(f"  the file holds the refinement of {h['chosen']} (chain RMS {ratio:.2f}x the "
                     "pixel RMS)")
    else:
        lines.append(f"  the file holds {h['chosen']}: the refinement was not kept (chain RMS {ratio:.2f}x "
                     "the pixel RMS: the joint readings are noisier than the pixels)")
    t = report["touch"]
    if t is not None:
        errs = ", ".join(f"{e:.3f}" for e in t["errors_mm"])
        lines += ["", f"touch test: corners {t['corners']}: {errs} mm (max {report['touch_err_mm']:.3f} mm)"]
    return "\n".join(lines)
