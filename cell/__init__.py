"""cell: a MuJoCo-simulated robotic work-cell with vision in the loop.

Importing the package sets ``MUJOCO_GL=egl`` when the user has not chosen a GL
backend, so every renderer in the package is headless by default.
"""

import os

if not os.environ.get("MUJOCO_GL"):  # (unset or empty)
    os.environ["MUJOCO_GL"] = "egl"

from cell.errors import (  # noqa: E402
    BenchError,
    CalibrationError,
    CellError,
    GraspError,
    IKError,
    JobError,
    MotionError,
    RobotError,
    ScenarioError,
    SimError,
    SweepError,
    VisionError,
)
from cell.lazy import lazy_names  # noqa: E402

__version__ = "0.1.0"

_WHERE = {  # the names most programs start from, loaded on first use
    "CameraModel": "camera",
    "KINDS": "catalogue",
    "LIGHTING_PRESETS": "catalogue",
    "MATERIALS": "catalogue",
    "Scenario": "scenario",
    "load_scenario": "scenario",
}

__all__ = sorted(_WHERE) + [
    "BenchError",
    "CalibrationError",
    "CellError",
    "GraspError",
    "IKError",
    "JobError",
    "MotionError",
    "RobotError",
    "ScenarioError",
    "SimError",
    "SweepError",
    "VisionError",
    "__version__",
]

__getattr__, _ = lazy_names(__name__, _WHERE, globals())


def __dir__() -> list[str]:
    return sorted(__all__)
