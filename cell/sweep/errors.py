"""The sweep's error: a sweep file, an output folder or a run that cannot go on as asked.

``SweepError`` is a :class:`~cell.errors.CellError`, so ``cell sweep`` prints it as one
line naming the culprit (escaped) and exits with status 2.
"""

from __future__ import annotations

from cell.errors import CellError

__all__ = ["SweepError"]


class SweepError(CellError):
    """A sweep file, its grid, the output folder or a run is invalid (names the culprit)."""
