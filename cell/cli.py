"""The ``cell`` command line: ``cell COMMAND [options]``.

Each command lives in its own module with a ``main(argv) -> int``; this file only
dispatches, so a command's imports (MuJoCo, OpenCV, ...) load only when it runs. Any
``CellError`` becomes one line on stderr and exit status 2. Ctrl-C (SIGINT) and a
polite kill (SIGTERM: ``kill``, ``timeout``, a job scheduler) stop a command the same way,
unwinding it so that its outputs stay whole or absent: one line, exit status 130 or 143.
Every message that echoes
a user's string goes through :func:`cell.text.escape`, so it cannot
carry terminal escapes, line breaks or undecodable bytes.
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
import threading
from importlib.metadata import PackageNotFoundError, version

from cell.errors import CellError, Terminated
from cell.text import escape

__all__ = ["COMMANDS", "main", "run"]

COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("cell.jobs.run", "run the sort job: calibrate, detect, pick and sort, report, replay"),
    "snapshot": ("cell.jobs.snapshot", "render what a camera sees when a part reaches the pick zone"),
    "detect": ("cell.vision.cli", "run the part detector on an image with its camera.json"),
    "calibrate": ("cell.calib.cli", "calibrate the wrist and overhead cameras from robot poses"),
    "sweep": ("cell.sweep.cli", "run a parameter sweep (local pool or Ray): results.csv, plots, summary"),
    "bench": ("cell.benchmarks", "benchmarks: render, vision, pick, calib, sort, sweep"),
}


def _version() -> str:
    try:
        return version("cell")
    except PackageNotFoundError:
        return "unknown (package not installed; run 'pip install -e .')"


def _usage() -> str:
    lines = ["usage: cell COMMAND [options]", "       cell --version", "", "commands:"]
    lines += [f"  {name:<10} {doc}" for name, (_, doc) in COMMANDS.items()]
    lines += ["", "Run 'cell COMMAND --help' for a command's options."]
    return "\n".join(lines)


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


def run() -> None:
    """The ``cell`` program: :func:`main` with the program's arguments, then exit with its
    status. Ctrl-C and SIGTERM are ignored once the command is done, while the interpreter
    shuts down (MuJoCo's EGL display, rerun's threads: tens of milliseconds): the work is
    whole by then, and a signal there gave a traceback of the shutdown, or a status of 130
    with no word. (From Python, call :func:`main`: it leaves the signals as they are.)"""
    status = main()
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):  # (an ignored signal stays ignored
            signal.signal(sig, signal.SIG_IGN)       # through the shutdown; a handler not)
    sys.exit(status)


def main(argv: list[str] | None = None) -> int:
    """Run ``cell COMMAND ...`` (``argv``; None: the program's own arguments) and return
    its exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:
        print(_usage(), file=sys.stderr)
        return 2
    if argv[0] in ("-h", "--help"):
        print(_usage())
        return 0
    if argv[0] == "--version":
        print(f"cell {_version()}")
        return 0
    name, rest = argv[0], argv[1:]
    if name not in COMMANDS:
        print(f"cell: error: unknown command {escape(repr(name))}; valid: {', '.join(COMMANDS)}",
              file=sys.stderr)
        return 2
    before = _catch_sigterm()
    try:
        module = importlib.import_module(COMMANDS[name][0])
        return int(module.main(rest) or 0)
    except Terminated:
        print(f"cell {name}: terminated", file=sys.stderr)
        return 143
    except CellError as exc:
        print(f"cell {name}: error: {escape(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        if isinstance(getattr(exc, "by", None), Terminated):  # (a sweep's, inside a bench)
            print(f"cell {name}: terminated", file=sys.stderr)
            return 143
        print(f"cell {name}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (`cell detect ... | head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    finally:
        if before is not None:
            signal.signal(signal.SIGTERM, before)


def _catch_sigterm() -> object | None:
    """Make SIGTERM raise :class:`Terminated` while a command runs; the handler it had
    (None when left alone: ignored by the caller, or not the main thread)."""
    before = signal.getsignal(signal.SIGTERM)
    if before is not signal.SIG_DFL or threading.current_thread() is not threading.main_thread():
        return None
    signal.signal(signal.SIGTERM, _terminate)
    return before


if __name__ == "__main__":
    run()
