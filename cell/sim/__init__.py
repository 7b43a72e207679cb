"""The simulated cell: scene building, parts, lighting, conveyor, cameras, sensor, arm.

Names load lazily (``from cell.sim import World``), so that reading the layout's
constants (``cell.sim.layout``, used by the jobs' policy and the reports) does not
import MuJoCo.
"""

from __future__ import annotations

from cell.lazy import lazy_names

__all__ = [
    "HOME",
    "JOINT_NAMES",
    "PRESETS",
    "CameraRig",
    "Conveyor",
    "Frame",
    "LightingPreset",
    "PartInfo",
    "SensorModel",
    "World",
    "add_arm",
    "apply_lighting",
    "build_arm",
    "build_spec",
    "propose_flange_board_poses",
    "true_camera_model",
]

_WHERE = {
    "CameraRig": "cameras", "Frame": "cameras", "true_camera_model": "cameras",
    "Conveyor": "conveyor", "PRESETS": "lighting", "LightingPreset": "lighting",
    "apply_lighting": "lighting", "SensorModel": "sensor", "PartInfo": "world",
    "World": "world", "build_spec": "spec", "HOME": "arm", "JOINT_NAMES": "arm",
    "add_arm": "arm", "build_arm": "arm", "propose_flange_board_poses": "board_poses",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
