"""``cell.calib``: checkerboard capture, intrinsics, hand-eye, calibration files.

The array side (board detection, intrinsics, hand-eye, refinement, files) works on numpy
arrays and returns frozen dataclasses; it never imports MuJoCo. The robot side
(``capture``, ``touch``, ``job``, and ``overhead``'s capture) drives the simulated cell:
it moves the arm, reads the joints and renders the cameras (the wrist camera sees the
table's board; the overhead camera sees a plate on the tool). Ground truth is read only by the job's scoring
(``report``, the touch test's landing point). Names load lazily, on first use, so that
reading the scenario's ``[calibration]`` section does not import OpenCV or scipy.
"""

from __future__ import annotations

from cell.lazy import lazy_names

_WHERE = {
    "CalibrationSettings": "settings",
    "Board": "board",
    "BoardView": "board",
    "detect_board": "board",
    "Intrinsics": "intrinsics",
    "calibrate_intrinsics": "intrinsics",
    "HAND_EYE_METHODS": "handeye",
    "HandEyeData": "handeye",
    "HandEyeEstimate": "handeye",
    "compare_hand_eye": "handeye",
    "consistency": "handeye",
    "solve_hand_eye": "handeye",
    "ROBOT_WORLD_METHODS": "eyetohand",
    "EyeToHandEstimate": "eyetohand",
    "compare_eye_to_hand": "eyetohand",
    "solve_eye_to_hand": "eyetohand",
    "Refinement": "refine",
    "EyeToHandRefinement": "refine",
    "refine_hand_eye": "refine",
    "refine_eye_to_hand": "refine",
    "CalibrationFile": "calfile",
    "CameraCalibration": "calfile",
    "load_calibration": "calfile",
    "write_calibration": "calfile",
    "ViewPlan": "planning",
    "plan_views": "planning",
    "Capture": "capture",
    "CapturedView": "capture",
    "Rig": "capture",
    "capture_views": "capture",
    "TouchResult": "touch",
    "PartTouchResult": "touch",
    "touch_test": "touch",
    "touch_parts": "touch",
    "OverheadCalibration": "overhead",
    "calibrate_overhead": "overhead",
    "solve_overhead": "overhead",
    "CalibrationSolution": "wrist",
    "WristCalibration": "wrist",
    "calibrate_wrist": "wrist",
    "solve_wrist": "wrist",
    "CalibrationRun": "job",
    "run_calibration": "job",
}

__all__ = sorted(_WHERE)

__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
