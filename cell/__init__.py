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
    VisionError,
)

__version__ = "0.1.0"

__all__ = [
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
    "VisionError",
    "__version__",
]
