"""Benchmarks behind ``cell bench NAME``: each module has ``main(argv) -> int``.

A benchmark prints ratios measured in one run (our code against a baseline or a physical
bound) plus absolute figures for information; ``--json`` prints one JSON object instead.
Each module also has ``parser() -> argparse.ArgumentParser`` (a :class:`cell.options.Parser`,
whose error line echoes the user's strings escaped; cheap: no MuJoCo or OpenCV import), which
``cell bench --help`` lists. Option values are checked by the parser (the ``int_in`` /
``float_in`` types below): a bad one is one error line, exit status 2. No
figure is ever NaN: a figure with no samples is ``None`` (``null`` in JSON, ``-`` in a
table).
"""

from __future__ import annotations

import importlib
import math
import sys

from cell.options import float_in, int_in  # (re-exported: the benchmarks' option types)
from cell.text import escape

__all__ = ["BENCHMARKS", "fmt", "float_in", "int_in", "main"]

BENCHMARKS: dict[str, str] = {
    "render": "cell.benchmarks.render",
    "vision": "cell.benchmarks.vision",
    "pick": "cell.benchmarks.pick",
    "calib": "cell.benchmarks.calib",
    "sort": "cell.benchmarks.sort",
    "sweep": "cell.benchmarks.sweep",
}

_USAGE = f"usage: cell bench {{{','.join(BENCHMARKS)}}} [options]"


def fmt(value: float | None, spec: str) -> str:
    """``value`` formatted with ``spec`` (e.g. ``'>8.3f'``); ``-`` (same width) when it is
    ``None`` or not finite (a figure with no samples)."""
    if value is None or not math.isfinite(value):
        width = "".join(c for c in spec.split(".")[0] if c.isdigit())
        return format("-", f">{width}" if width else "")
    return format(value, spec)


def _help() -> str:
    lines = [_USAGE, "", "Benchmarks (each prints a table, or one JSON object with --json):"]
    parsers = {name: importlib.import_module(mod).parser() for name, mod in BENCHMARKS.items()}
    lines += [f"  {name:<8} {p.description}" for name, p in parsers.items()]
    lines += ["", "Run 'cell bench NAME --help' for one benchmark's options; all of them:"]
    for p in parsers.values():
        lines += ["", *p.format_help().rstrip().splitlines()]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if argv and argv[0] in ("-h", "--help"):
        print(_help())
        return 0
    if not argv:
        print(f"{_USAGE}\ncell bench: error: name a benchmark: {', '.join(BENCHMARKS)} "
              "('cell bench --help' lists their options)", file=sys.stderr)
        return 2
    name = argv[0]
    if name not in BENCHMARKS:
        print(f"{_USAGE}\ncell bench: error: unknown benchmark '{escape(name)}'; valid: "
              f"{', '.join(BENCHMARKS)}", file=sys.stderr)
        return 2
    return int(importlib.import_module(BENCHMARKS[name]).main(argv[1:]) or 0)
