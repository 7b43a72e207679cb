"""The simulated cell: scene building, parts, lighting, conveyor, cameras, sensor."""

from cell.sim.cameras import CameraRig, Frame, true_camera_model
from cell.sim.conveyor import Conveyor
from cell.sim.lighting import PRESETS, LightingPreset, apply_lighting
from cell.sim.sensor import SensorModel
from cell.sim.world import PartInfo, World, build_spec

__all__ = [
    "PRESETS",
    "CameraRig",
    "Conveyor",
    "Frame",
    "LightingPreset",
    "PartInfo",
    "SensorModel",
    "World",
    "apply_lighting",
    "build_spec",
    "true_camera_model",
]

from cell.sim.arm import HOME, add_arm, build_arm  # noqa: E402

__all__ += ["HOME", "add_arm", "build_arm"]
