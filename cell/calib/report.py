"""The calibration report: errors against the simulator's ground truth, as JSON and a table.

Ground truth enters here only, to score: each camera's true intrinsics and distortion and
its true pose (:class:`CameraTruth`, read from the simulator by the job: the wrist
camera's mount on the flange, the overhead camera's pose in the base frame), and where
the touch test's points truly are. Signed errors are estimate minus truth; relative
errors are that over the truth (``k1_rel_err`` is null when the true k1 is 0). Every
number is finite: the JSON is strict (no NaN).

Per camera: ``intrinsics`` (``cv2.calibrateCamera``'s), ``hand_eye`` (every closed-form
method, ``refined``, the ``chosen`` method and what the file holds, ``kept``), the touch
test, the capture's counts and the wall time. An overhead calibration whose refinement
freed the intrinsics adds ``intrinsics_refined`` (the same errors for the refined ones)
and says in ``intrinsics_held`` which of the two the file holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cell.calib.touch import PartTouchResult, TouchResult
from cell.calib.transforms import pose_error

__all__ = ["CameraTruth", "format_camera", "held_intrinsics", "score_camera"]

_RMS_BAR_PX = 0.3  # reprojection RMS (px) over which the printed report warns


@dataclass(frozen=True, eq=False)
class CameraTruth:
    """GROUND TRUTH of a camera (from the simulator): ``K`` (3x3, px), ``dist`` (5,), and its
    pose (4x4, m) named ``pose_name``: ``T_flange_camera`` (wrist) or ``T_base_camera``."""

    K: np.ndarray
    dist: np.ndarray
    pose_name: str
    pose: np.ndarray


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _pose_entry(T_est: np.ndarray, truth: CameraTruth, consistency: float) -> dict:
    rot, trans = pose_error(T_est, truth.pose)
    return {"rot_err_deg": rot, "trans_err_mm": 1000.0 * trans, "consistency_px": _finite(consistency)}


def _k_errors(K: np.ndarray, dist: np.ndarray, truth: CameraTruth) -> dict:
    Kt = truth.K
    k1, k1t = float(dist[0]), float(truth.dist[0])
    return {"fx_rel_err": float(K[0, 0] / Kt[0, 0] - 1.0), "fy_rel_err": float(K[1, 1] / Kt[1, 1] - 1.0),
            "cx_err_px": float(K[0, 2] - Kt[0, 2]), "cy_err_px": float(K[1, 2] - Kt[1, 2]),
            "k1_rel_err": None if k1t == 0 else k1 / k1t - 1.0, "k1": k1, "k1_true": k1t}


def held_intrinsics(result: object) -> str:
    """Which intrinsics the calibrated camera holds: ``"refined"`` (an overhead refinement
    that freed them, kept) or ``"calibrateCamera"``."""
    refinement = result.refinement
    return "refined" if result.kept == "refined" and getattr(refinement, "free_intrinsics", False) \
        else "calibrateCamera"


def _touch_entry(touch: TouchResult | PartTouchResult | None) -> dict | None:
    if touch is None:
        return None
    blocked = [bool(b) for b in touch.blocked] or [False] * len(touch.errors_mm)
    if isinstance(touch, PartTouchResult):
        return {"parts": list(touch.kinds), "errors_mm": [float(e) for e in touch.errors_mm],
                "located_mm": [float(e) for e in touch.located_mm], "blocked": blocked}
    return {"corners": list(touch.corner_ids), "errors_mm": [float(e) for e in touch.errors_mm],
            "blocked": blocked}


def score_camera(result: object, truth: CameraTruth, touch: TouchResult | PartTouchResult | None) -> dict:
    """The report of one camera's calibration (a ``WristCalibration`` or an
    ``OverheadCalibration``; a JSON-ready dict, see the module docstring)."""
    name = truth.pose_name
    intrinsics = {
        **_k_errors(result.intrinsics.K, result.intrinsics.dist, truth),
        "reproj_rms_px": result.intrinsics.rms,
        "view_rms_px": [float(v) for v in result.intrinsics.view_rms],
        "views_used": len(result.used), "views_rejected": result.rejected,
    }
    hand_eye: dict = {e.method: _pose_entry(getattr(e, name), truth, e.consistency_px)
                      for e in result.hand_eye}
    hand_eye["refined"] = _pose_entry(getattr(result.refinement, name), truth, result.refinement.rms_px)
    hand_eye["chosen"] = result.chosen
    hand_eye["kept"] = result.kept
    hand_eye["chain_to_pixel_rms"] = result.refinement.rms_px / result.intrinsics.rms
    capture = result.capture
    out = {
        "pose": name,
        "intrinsics": {k: (float(v) if isinstance(v, float | np.floating) else v)
                       for k, v in intrinsics.items()},
        "hand_eye": hand_eye,
        "touch_err_mm": None if touch is None else float(touch.errors_mm.max()),
        "touch": _touch_entry(touch),
        "capture": {"views": len(capture.views), "unreachable": capture.unreachable,
                    "blocked": capture.blocked,
                    "detectors": [d.detector if d is not None else None for d in result.detections]},
    }
    if getattr(result.refinement, "free_intrinsics", False):
        out["intrinsics_refined"] = _k_errors(result.refinement.K, result.refinement.dist, truth)
        out["intrinsics_refined"]["reproj_rms_px"] = result.refinement.rms_px
    out["intrinsics_held"] = held_intrinsics(result)
    return out


def _pct(x: float) -> str:
    return f"{100 * x:+.4f} %"


def _k_lines(i: dict) -> list[str]:
    return [f"  fx {_pct(i['fx_rel_err'])}   fy {_pct(i['fy_rel_err'])}   cx {i['cx_err_px']:+.3f} px   "
            f"cy {i['cy_err_px']:+.3f} px",
            f"  k1 {i['k1']:+.5f} (true {i['k1_true']:+.5f}"
            + ("" if i["k1_rel_err"] is None else f", {_pct(i['k1_rel_err'])}") + ")"]


def format_camera(camera: str, report: dict) -> str:
    """One camera's report (``report["cameras"][camera]``) as a table (text)."""
    i, h = report["intrinsics"], report["hand_eye"]
    c = report["capture"]
    target = "the tool plate" if report["pose"] == "T_base_camera" else "the board"
    lines = [
        f"{camera} camera: {i['views_used']} views used, {i['views_rejected']} without {target}, "
        f"{c['unreachable']} poses unreachable, {c['blocked']} blocked",
        "",
        "intrinsics, calibrateCamera (estimate - truth)",
        *_k_lines(i),
        f"  reprojection RMS {i['reproj_rms_px']:.4f} px (views {min(i['view_rms_px']):.3f}"
        f"..{max(i['view_rms_px']):.3f})",
    ]
    if i["reproj_rms_px"] > _RMS_BAR_PX:
        hint = (" (a decentred lens wants calibration.overhead_distortion_terms = 4)"
                if report["pose"] == "T_base_camera" else "")
        lines.append(f"  warning: over {_RMS_BAR_PX} px: the lens model does not fit these views"
                     f"{hint}; the camera's pose may be off by degrees")
    if "intrinsics_refined" in report:
        r = report["intrinsics_refined"]
        held = "the file holds these" if report["intrinsics_held"] == "refined" else "not kept"
        lines += [f"intrinsics, refined with the chain ({held})", *_k_lines(r),
                  f"  reprojection RMS {r['reproj_rms_px']:.4f} px"]
    lines += ["", f"hand-eye {report['pose']:<18} {'rot (deg)':>10} {'trans (mm)':>11} "
              f"{'consistency (px)':>17}"]
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
        what = f"corners {t['corners']}" if "corners" in t else f"parts on the belt {', '.join(t['parts'])}"
        lines += ["", f"touch test: {what}: {errs} mm (max {report['touch_err_mm']:.3f} mm)"]
        if "located_mm" in t:
            lines.append("  located on the belt through the camera: "
                         + ", ".join(f"{e:.3f}" for e in t["located_mm"]) + " mm from the truth")
        if any(t["blocked"]):
            lines.append(f"  warning: the cup met something short of {sum(t['blocked'])} of its "
                         f"{len(t['blocked'])} points (or they lay below the table): the calibration "
                         "puts them too low, by more than the standoff")
    return "\n".join(lines)
