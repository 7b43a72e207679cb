"""``cell detect IMAGE --camera camera.json``: run the part detector on any image.

The camera file is the ``camera.json`` that ``cell snapshot`` writes (width, height, K,
dist, T_world_camera in OpenCV axes), or a user's own with the same keys. Detector
settings come from the ``[vision]`` section of ``--scenario FILE`` (defaults without
one), then ``--set key=value`` overrides: ``vision.threshold_method=otsu``, or simply
``threshold_method=otsu`` (a key of the vision section needs no prefix).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import cv2

from cell.camera import CameraModel
from cell.errors import VisionError
from cell.scenario import load_scenario, scenario_from_dict
from cell.vision.detector import PartDetector
from cell.vision.settings import VisionSettings

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cell detect", description=__doc__.splitlines()[0])
    p.add_argument("image", help="image file (PNG, JPEG, ...), read as RGB")
    p.add_argument("--camera", required=True, help="camera.json with K, dist, T_world_camera")
    p.add_argument("--scenario", default=None, help="scenario TOML whose [vision] section to use")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a vision setting (vision.KEY=VALUE or KEY=VALUE); repeatable")
    p.add_argument("--json", action="store_true", help="print the detections as JSON")
    return p


def _qualify(assignment: str) -> str:
    key = assignment.partition("=")[0].strip()
    names = {f.name for f in dataclasses.fields(VisionSettings)}
    return f"vision.{assignment.strip()}" if key in names else assignment


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    overrides = [_qualify(a) for a in args.overrides]
    if args.scenario:
        scenario = load_scenario(args.scenario, overrides=overrides)
    else:
        scenario = scenario_from_dict({}, overrides=overrides)
    camera = CameraModel.load(args.camera)
    path = Path(args.image)
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise VisionError(f"{path}: cannot read the image (missing, or not an image file)")
    rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    detector = PartDetector(scenario.vision)
    t0 = time.perf_counter()
    detections = detector.detect(rgb, camera)
    ms = (time.perf_counter() - t0) * 1e3
    if args.json:
        print(json.dumps({"image": str(path), "latency_ms": ms,
                          "detections": [d.to_dict() for d in detections]}, indent=2))
        return 0
    print(f"{path}: {len(detections)} detection(s) in {ms:.1f} ms")
    if detections:
        print(f"{'id':>3} {'kind':<11} {'conf':>5} {'material':<8} {'conf':>5} "
              f"{'u':>7} {'v':>7} {'x mm':>8} {'y mm':>8} {'yaw deg':>8} {'partial':>7}")
    for d in detections:
        x, y = ("-", "-") if d.position is None else (f"{d.position[0] * 1e3:.1f}",
                                                      f"{d.position[1] * 1e3:.1f}")
        print(f"{d.id:>3} {d.kind:<11} {d.kind_confidence:>5.2f} {d.material:<8} "
              f"{d.material_confidence:>5.2f} {d.centroid[0]:>7.1f} {d.centroid[1]:>7.1f} "
              f"{x:>8} {y:>8} {d.yaw * 57.29578:>8.1f} {str(d.partial):>7}")
    return 0
