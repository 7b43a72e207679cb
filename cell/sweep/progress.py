"""The sweep's progress bar: runs done, elapsed and time left, on stderr when it is a terminal.

One line, redrawn in place (``\\r``) at most five times a second; the time left is the
runs still to do at the rate of this session's finished runs (resumed rows do not count
towards the rate). Nothing is drawn when stderr is not a terminal (a log file, a pipe).
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress", "clock"]

_WIDTH = 24


def clock(seconds: float) -> str:
    """``seconds`` as ``1h02m``, ``3m05s`` or ``12s``."""
    s = max(0, int(round(seconds)))
    if s >= 3600:
        return f"{s // 3600}h{s % 3600 // 60:02d}m"
    if s >= 60:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s}s"


class Progress:
    """Shows ``done`` of ``total`` runs (``resumed`` of them from an earlier session)."""

    def __init__(self, total: int, resumed: int, *, stream: TextIO | None = None,
                 enabled: bool | None = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.total, self.resumed, self.done = total, resumed, resumed
        self.start = time.perf_counter()
        self._shown = 0.0

    def line(self) -> str:
        """The bar's text now."""
        elapsed = time.perf_counter() - self.start
        fresh = self.done - self.resumed
        left = self.total - self.done
        eta = "?" if fresh == 0 else clock(elapsed / fresh * left)
        filled = _WIDTH * self.done // max(self.total, 1)
        bar = "#" * filled + "." * (_WIDTH - filled)
        return (f"[{bar}] {self.done}/{self.total} runs, {clock(elapsed)} elapsed, "
                f"{eta if left else '0s'} left")

    def advance(self, runs: int) -> None:
        """``runs`` more runs are done."""
        self.done += runs
        now = time.perf_counter()
        if self.enabled and (now - self._shown >= 0.2 or self.done >= self.total):
            self._shown = now
            self.stream.write("\r" + self.line() + "\033[K")
            self.stream.flush()

    def close(self) -> None:
        """End the bar's line."""
        if self.enabled:
            self.stream.write("\r" + self.line() + "\033[K\n")
            self.stream.flush()
