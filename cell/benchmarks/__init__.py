"""Benchmarks behind ``cell bench NAME``: each module has ``main(argv) -> int``.

A benchmark prints ratios measured in one run (our code against a baseline or a physical
bound) plus absolute figures for information; ``--json`` prints one JSON object instead.
"""

from __future__ import annotations

import importlib
import sys

__all__ = ["BENCHMARKS", "main"]

BENCHMARKS: dict[str, str] = {
    "render": "cell.benchmarks.render",
    "vision": "cell.benchmarks.vision",
    "pick": "cell.benchmarks.pick",
}


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print(f"usage: cell bench {{{','.join(BENCHMARKS)}}} [--json]")
        return 0 if argv else 2
    name = argv[0]
    if name not in BENCHMARKS:
        print(f"cell bench: error: unknown benchmark '{name}'; valid: {', '.join(BENCHMARKS)}",
              file=sys.stderr)
        return 2
    return int(importlib.import_module(BENCHMARKS[name]).main(argv[1:]) or 0)
