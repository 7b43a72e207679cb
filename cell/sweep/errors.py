"""The sweep's error: a sweep file, an output folder or a run that cannot go on as asked.

``SweepError`` is a :class:`~cell.errors.CellError` (defined there with the other
packages' errors, re-exported here), so ``cell sweep`` prints it as one line naming the
culprit (escaped) and exits with status 2.
"""

from __future__ import annotations

from cell.errors import SweepError

__all__ = ["SweepError"]
