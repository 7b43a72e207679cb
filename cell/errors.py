"""The one error hierarchy of the package.

Every error the package raises on purpose is a ``CellError``; each package has its
own subclass. Messages name the culprit (a key, an argument, a part) and, where
there is a finite set of valid choices, list them.
"""


class CellError(Exception):
    """Base of every error raised on purpose by ``cell``."""


class ScenarioError(CellError):
    """A scenario file or ``--set`` override is invalid (names the key and the file)."""


class SimError(CellError):
    """The simulated world cannot be built or driven as asked."""


class VisionError(CellError):
    """A vision function got input of the wrong type, dtype or shape."""


class CalibrationError(CellError):
    """Calibration data is missing, degenerate or inconsistent."""


class RobotError(CellError):
    """The robot was asked something meaningless: a NaN or wrong-length joint vector, an
    unknown frame, kind or bin (a caller's bug, not a pick's outcome). Base of the
    outcomes below (IKError, MotionError and its GraspError)."""


class IKError(RobotError):
    """Inverse kinematics failed: target unreachable or solver did not converge."""


class MotionError(RobotError):
    """A motion cannot be planned or executed (limits, grasp lost, timeout)."""


class GraspError(MotionError):
    """The vacuum switch reports no part held: the grasp never sealed (``lost`` False) or
    the part fell off the cup on its way to the bin (``lost`` True); or it reports one
    still held after the cup was vented over the bin (``lost`` True: jammed on the tool)."""

    def __init__(self, message: str, *, lost: bool = False) -> None:
        super().__init__(message)
        self.lost = lost


class BenchError(CellError):
    """A benchmark cannot run as asked (a count out of range, an unknown preset), or its
    runs failed."""


class JobError(CellError):
    """A job cannot run as asked (a detector that does not load, an unusable output path)."""


class SweepError(CellError):
    """A sweep file, its grid, the output folder or a run is invalid (names the culprit)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread while a command runs (``cell.cli``), so that
    the command unwinds as on Ctrl-C (its temporary files removed, its workers stopped)
    and says ``terminated``. (Here, not in ``cell.cli``: ``python -m cell.cli`` loads that
    module a second time as ``__main__``, with a class of its own.)"""


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
    "SweepError",
    "Terminated",
    "VisionError",
]
