"""``cell bench calib``: both cameras' calibrations scored against the simulator's ground truth.

For each set-up (``default``: the default scenario; ``distortion``: the same with lens
distortion ``sensor.distortion = [-0.2, 0.05, 0, 0, 0]``; ``joint_noise``: the same with
``calibration.joint_noise_deg = 0.01``) and each seed (from ``SEED_BASE`` on: the tests use
seeds below 1000) it runs ``cell calibrate --camera all`` (wrist, then overhead) with
``--poses`` views per camera, and reports per camera the median and the worst over the
seeds of: the focal error of the intrinsics the file holds (the larger of fx's and fy's,
relative), the intrinsic calibration's reprojection RMS (px), the hand-eye error of the
pose the file holds (``hand_eye``: the refinement when it was kept, else the closed-form
method chosen by consistency; rotation in degrees, translation in mm), each closed-form
method's and the refinement's errors, the touch test's largest miss (mm), k1's relative
error when the lens distorts, and the wall time per camera (s). ``required`` holds the
must-reach bars (issue 13) and ``aim`` the aims; ``meets_required`` says whether every
seed's figures are within the bars (set for 20 poses). ``--camera`` calibrates one camera
only, and ``--set KEY=VALUE`` changes a scenario key in every set-up (to measure a choice,
e.g. ``calibration.refine_intrinsics=false``; not a key the bench sets itself: the seed,
the poses, a chosen set-up's keys). Ground truth is read only to score. A figure
with no samples is ``None`` (``null`` in JSON, ``-`` in the table); never NaN.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from cell.benchmarks import fmt, int_in
from cell.errors import BenchError, CellError
from cell.options import Parser

__all__ = ["AIM", "REQUIRED", "SEED_BASE", "SETUPS", "main", "parser", "run"]

SEED_BASE = 1000  # runs use seeds SEED_BASE + i; tests use seeds below 1000
_MAX_SEED = 2**63 - 1  # the scenario's seed range
_MAX_SEEDS = 1000
SETUPS = {
    "default": (),
    "distortion": ("sensor.distortion=[-0.2, 0.05, 0, 0, 0]",),
    "joint_noise": ("calibration.joint_noise_deg=0.01",),
}
REQUIRED = {"focal_rel_err": 0.002, "reproj_rms_px": 0.3, "hand_eye_rot_deg": 0.05,
            "hand_eye_trans_mm": 0.5, "touch_err_mm": 1.0, "k1_rel_err": 0.05}
AIM = {"focal_rel_err": 0.001, "hand_eye_rot_deg": 0.02, "hand_eye_trans_mm": 0.15}
_FIGURES = ("focal_rel_err", "reproj_rms_px", "hand_eye_rot_deg", "hand_eye_trans_mm", "touch_err_mm",
            "k1_rel_err", "wall_s")


def _row(report: dict) -> dict:
    """One camera's figures from its ``cell calibrate`` report (errors as magnitudes)."""
    held = report["intrinsics_refined"] if report["intrinsics_held"] == "refined" else report["intrinsics"]
    hand_eye = report["hand_eye"]
    kept = hand_eye[hand_eye["kept"]]
    methods = {name: {"rot_deg": e["rot_err_deg"], "trans_mm": e["trans_err_mm"]}
               for name, e in hand_eye.items() if isinstance(e, dict)}
    return {
        "focal_rel_err": max(abs(held["fx_rel_err"]), abs(held["fy_rel_err"])),
        "reproj_rms_px": report["intrinsics"]["reproj_rms_px"],
        "hand_eye_rot_deg": kept["rot_err_deg"], "hand_eye_trans_mm": kept["trans_err_mm"],
        "touch_err_mm": report["touch_err_mm"],
        "k1_rel_err": None if held["k1_rel_err"] is None else abs(held["k1_rel_err"]),
        "wall_s": report["wall_s"],
        "chosen": hand_eye["chosen"], "kept": hand_eye["kept"], "intrinsics_held": report["intrinsics_held"],
        "views_used": report["intrinsics"]["views_used"], "methods": methods,
    }


def _stats(values: list) -> dict:
    """Median and worst (largest) of the figures that are not ``None``; ``None`` if none."""
    v = [x for x in values if x is not None]
    return {"median": float(np.median(v)) if v else None, "worst": float(np.max(v)) if v else None}


def _summary(rows: list[dict], *, distorted: bool) -> dict:
    out = {k: _stats([r[k] for r in rows]) for k in _FIGURES}
    names = list(rows[0]["methods"]) if rows else []
    out["methods"] = {name: {"rot_deg": _stats([r["methods"][name]["rot_deg"] for r in rows]),
                             "trans_mm": _stats([r["methods"][name]["trans_mm"] for r in rows])}
                      for name in names}
    out["kept"] = sorted({r["kept"] for r in rows})
    failures = [f"{k} {out[k]['worst']:.4g} > {REQUIRED[k]:g}" for k in REQUIRED
                if (k != "k1_rel_err" or distorted) and out[k]["worst"] is not None
                and out[k]["worst"] > REQUIRED[k]]
    if distorted and out["k1_rel_err"]["worst"] is None:
        failures.append("k1_rel_err: no figure")
    out["meets_required"] = not failures
    out["failures"] = failures
    return out


def run(*, seeds: int = 10, seed_base: int = SEED_BASE, poses: int = 20, setups: list[str] | None = None,
        overrides: tuple[str, ...] = (), camera: str = "all") -> dict:
    """Calibrate ``camera`` (``all``: both) ``seeds`` times per set-up (seeds ``seed_base``
    on, keep them at 1000 or above) with ``poses`` views each, the scenario keys
    ``overrides`` (``KEY=VALUE``) applied to every set-up first; returns the report
    (module docstring)."""
    from cell.calib.job import run_calibration
    from cell.scenario import scenario_from_dict

    names = list(SETUPS) if setups is None else [s for s in SETUPS if s in setups]
    if not names or (setups is not None and len(names) != len(set(setups))):
        raise BenchError(f"setups: give one or more of {', '.join(SETUPS)}, got {setups}")
    if not 1 <= seeds <= _MAX_SEEDS:
        raise BenchError(f"seeds: must be 1 to {_MAX_SEEDS}, got {seeds}")
    t0 = time.perf_counter()
    out: dict = {"seeds": seeds, "seed_base": seed_base, "poses": poses, "camera": camera,
                 "overrides": list(overrides),
                 "required": REQUIRED, "aim": AIM, "setups": {}}
    for name in names:
        keys = [*overrides, *SETUPS[name], f"calibration.poses={poses}"]
        rows: dict[str, list[dict]] = {}
        for i in range(seeds):
            scenario = scenario_from_dict({"seed": seed_base + i}, overrides=keys)
            report = run_calibration(scenario, camera=camera).report
            for name_, camera_report in report["cameras"].items():
                rows.setdefault(name_, []).append({"seed": seed_base + i, **_row(camera_report)})
        distorted = name == "distortion"
        out["setups"][name] = {
            "overrides": list(SETUPS[name]),
            "cameras": {name_: {"summary": _summary(r, distorted=distorted), "runs": r}
                        for name_, r in rows.items()},
        }
    out["meets_required"] = all(c["summary"]["meets_required"] for s in out["setups"].values()
                                for c in s["cameras"].values())
    out["wall_s"] = time.perf_counter() - t0
    return out


def _mw(stat: dict, spec: str, scale: float = 1.0) -> str:
    m, w = stat["median"], stat["worst"]
    return (f"{fmt(None if m is None else m * scale, spec)} / "
            f"{fmt(None if w is None else w * scale, spec)}")


def _print(report: dict) -> None:
    extra = f", with {' '.join(report['overrides'])}" if report["overrides"] else ""
    print(f"cell bench calib: {report['seeds']} seed(s) from {report['seed_base']}, {report['poses']} poses "
          f"per camera{extra}; median / worst over the seeds; hand-eye = the pose the file holds")
    head = (f"{'set-up':<12} {'camera':<9} {'focal %':>17} {'RMS px':>15} {'rot deg':>15} {'trans mm':>13} "
            f"{'touch mm':>13} {'k1 %':>13} {'wall s':>11}  kept")
    print(head)
    for name, setup in report["setups"].items():
        for camera, c in setup["cameras"].items():
            s = c["summary"]
            print(f"{name:<12} {camera:<9} {_mw(s['focal_rel_err'], '7.4f', 100)} "
                  f"{_mw(s['reproj_rms_px'], '6.4f')} {_mw(s['hand_eye_rot_deg'], '6.4f')} "
                  f"{_mw(s['hand_eye_trans_mm'], '5.3f')} {_mw(s['touch_err_mm'], '5.3f')} "
                  f"{_mw(s['k1_rel_err'], '5.2f', 100)} {_mw(s['wall_s'], '4.1f')}  {', '.join(s['kept'])}")
    print("\nper method (rot deg, trans mm: median / worst)")
    for name, setup in report["setups"].items():
        for camera, c in setup["cameras"].items():
            for method, m in c["summary"]["methods"].items():
                print(f"{name:<12} {camera:<9} {method:<11} {_mw(m['rot_deg'], '6.4f')}   "
                      f"{_mw(m['trans_mm'], '6.3f')}")
    req = report["required"]
    print("\nrequired (every seed, every camera; bars set for 20 poses): focal <= "
          f"{100 * req['focal_rel_err']:g} %, RMS <= {req['reproj_rms_px']:g} px, hand-eye <= "
          f"{req['hand_eye_rot_deg']:g} deg and <= "
          f"{req['hand_eye_trans_mm']:g} mm, touch <= {req['touch_err_mm']:g} mm, k1 within "
          f"{100 * req['k1_rel_err']:g} % with distortion: "
          + ("met" if report["meets_required"] else "NOT met"))
    for name, setup in report["setups"].items():
        for camera, c in setup["cameras"].items():
            for failure in c["summary"]["failures"]:
                print(f"  {name} {camera}: {failure}")
    print(f"wall time {report['wall_s']:.1f} s")


def parser() -> argparse.ArgumentParser:
    p = Parser(
        prog="cell bench calib",
        description="both cameras' calibrations (cell calibrate --camera all) against the simulator's "
        "ground truth: default, with lens distortion, with joint-reading noise")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quick", action="store_true",
                   help="1 seed and 8 poses per camera (smoke test; --seeds and --poses override)")
    p.add_argument("--seeds", type=int_in(1, _MAX_SEEDS), default=None, metavar="N",
                   help=f"seeds per set-up, 1 to {_MAX_SEEDS} (default 10)")
    p.add_argument("--seed-base", type=int_in(1000, _MAX_SEED), default=SEED_BASE, metavar="N",
                   help=f"first seed, 1000 to 2**63-1 less the seed count (default {SEED_BASE}; tests use "
                   "seeds below 1000)")
    p.add_argument("--poses", type=int_in(3, 200), default=None, metavar="N",
                   help="views per camera, 3 to 200 (default 20)")
    p.add_argument("--setups", default=None, metavar="S,S,...",
                   help=f"comma-separated set-ups, one or more of: {', '.join(SETUPS)} (default: all)")
    p.add_argument("--camera", default="all", choices=("wrist", "overhead", "all"),
                   help="the camera(s) to calibrate (default all: wrist, then overhead)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key in every set-up (dotted for sections, e.g. "
                   "calibration.refine_intrinsics=false); repeatable")
    return p


def main(argv: list[str]) -> int:
    parser_ = parser()
    args = parser_.parse_args(argv)
    setups = None
    if args.setups is not None:
        setups = [s.strip() for s in args.setups.split(",") if s.strip()]
        bad = [s for s in setups if s not in SETUPS]
        if bad or not setups or len(set(setups)) != len(setups):
            what = (f"unknown {', '.join(bad)}; valid:" if bad else
                    "each once, one or more of:" if setups else "give one or more of:")
            parser_.error(f"argument --setups: {what} {', '.join(SETUPS)}")
    seeds = args.seeds if args.seeds is not None else (1 if args.quick else 10)
    poses = args.poses if args.poses is not None else (8 if args.quick else 20)
    if args.seed_base > _MAX_SEED - (seeds - 1):
        parser_.error(f"argument --seed-base: must be at most {_MAX_SEED - (seeds - 1)} with {seeds} "
                      "seeds (the last seed is at most 2**63-1)")
    try:  # a bad key or value is one error line (the scenario's message names the key)
        from cell.scenario import scenario_from_dict

        scenario_from_dict({}, overrides=list(args.overrides))
    except CellError as exc:
        parser_.error(f"argument --set: {exc}")
    owned = {"seed": "--seed-base", "calibration.poses": "--poses"}  # (they were overridden unsaid)
    for name in setups or SETUPS:
        owned.update({k.split("=", 1)[0]: f"the set-up {name!r}" for k in SETUPS[name]})
    for assignment in args.overrides:
        key = assignment.split("=", 1)[0].strip()
        if key in owned:
            parser_.error(f"argument --set: {key} is set by {owned[key]} in this benchmark")
    report = run(seeds=seeds, seed_base=args.seed_base, poses=poses, setups=setups,
                 overrides=tuple(args.overrides), camera=args.camera)
    if args.json:
        print(json.dumps(report, indent=2, allow_nan=False))
    else:
        _print(report)
    return 0
