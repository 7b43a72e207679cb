"""The ``cell`` command line: ``cell COMMAND [options]``.

Each command lives in its own module with a ``main(argv) -> int``; this file only
dispatches, so a command's imports (MuJoCo, OpenCV, ...) load only when it runs. Any
``CellError`` becomes one line on stderr and exit status 2.
"""

from __future__ import annotations

import importlib
import sys

from cell.errors import CellError

__all__ = ["COMMANDS", "main"]

COMMANDS: dict[str, tuple[str, str]] = {
    "snapshot": ("cell.jobs.snapshot", "render what a camera sees when a part reaches the pick zone"),
    "detect": ("cell.vision.cli", "run the part detector on an image with its camera.json"),
    "bench": ("cell.benchmarks", "benchmarks: render, vision, pick"),
}


def _usage() -> str:
    lines = ["usage: cell COMMAND [options]", "", "commands:"]
    lines += [f"  {name:<10} {doc}" for name, (_, doc) in COMMANDS.items()]
    lines += ["", "Run 'cell COMMAND --help' for a command's options."]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(_usage())
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    if name not in COMMANDS:
        print(f"cell: error: unknown command '{name}'; valid: {', '.join(COMMANDS)}", file=sys.stderr)
        return 2
    try:
        module = importlib.import_module(COMMANDS[name][0])
        return int(module.main(rest) or 0)
    except CellError as exc:
        print(f"cell {name}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"cell {name}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
