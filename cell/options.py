"""Command-line option helpers shared by every ``cell`` command.

``Parser`` is argparse whose error line echoes the user's strings escaped (usage, then
one line, exit status 2); ``int_in`` and ``float_in`` are argparse ``type``s that accept
a finite number in a closed range and say the range when they refuse.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable

from cell.text import escape

__all__ = ["Parser", "float_in", "int_in"]


class Parser(argparse.ArgumentParser):
    """argparse whose error line echoes the user's strings escaped."""

    def error(self, message: str):
        self.print_usage(sys.stderr)
        self.exit(2, f"{self.prog}: error: {escape(message)}\n")


def int_in(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse ``type``: an integer from ``lo`` to ``hi`` (inclusive)."""

    def parse(text: str) -> int:
        try:
            value = int(text.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be an integer from {lo} to {hi}, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be {lo} to {hi}, got {value}")
        return value

    parse.__name__ = "integer"  # (named in argparse's own messages)
    return parse


def float_in(lo: float, hi: float) -> Callable[[str], float]:
    """An argparse ``type``: a finite number from ``lo`` to ``hi`` (inclusive)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except (ValueError, OverflowError):
            raise argparse.ArgumentTypeError(f"must be a number from {lo:g} to {hi:g}, "
                                             f"got {text!r}") from None
        if not math.isfinite(value) or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be a finite number from {lo:g} to {hi:g}, "
                                             f"got {text!r}")
        return value

    parse.__name__ = "number"
    return parse
