"""``cell sweep``: run a parameter sweep and write its results, plots and summary.

``cell sweep SWEEP.toml --out DIR [--backend local|ray] [--workers N] [--address ADDR]
[--resume]`` runs every grid point and seed of the sweep file (``scenarios/sweeps/``
holds the studies) and writes ``DIR/results.csv`` (one row per run, written as runs
finish), the study's PNG plots and ``DIR/summary.md``. A progress bar shows on a
terminal. Ctrl-C (or a killed worker) keeps every finished row: the same command with
``--resume`` does only the rest. ``--backend ray`` runs the same grid on Ray, a local
instance or the cluster at ``--address``.
"""

from __future__ import annotations

import sys

from cell.errors import Terminated
from cell.options import Parser, int_in
from cell.sweep.progress import clock
from cell.sweep.runner import BACKENDS, SweepInterrupted, SweepOptions, run_sweep
from cell.text import escape

__all__ = ["main", "parser"]

MAX_WORKERS = 1024


def parser() -> Parser:
    p = Parser(prog="cell sweep",
               description="run a parameter sweep: results.csv (one row per run, written as runs "
               "finish), the study's PNG plots and summary.md; Ctrl-C keeps the finished rows and "
               "--resume does the rest")
    p.add_argument("sweep", help="sweep file (TOML; see scenarios/sweeps/)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output folder: created, or continued with --resume")
    p.add_argument("--backend", choices=BACKENDS, default="local",
                   help="local: a pool of processes here (default); ray: Ray tasks")
    p.add_argument("--workers", type=int_in(1, MAX_WORKERS), default=None, metavar="N",
                   help=f"parallel runs, 1 to {MAX_WORKERS} (default: this machine's CPUs; with "
                   "--address, the cluster's)")
    p.add_argument("--address", default=None, metavar="ADDR",
                   help="with --backend ray: a running Ray cluster (ray://HOST:10001, HOST:6379 or "
                   "auto); default: start a local instance")
    p.add_argument("--resume", action="store_true",
                   help="continue the sweep in --out: finished runs are skipped")
    return p


def main(argv: list[str]) -> int:
    p = parser()
    args = p.parse_args(argv)
    if args.address is not None and args.backend != "ray":
        p.error("argument --address: only with --backend ray")
    if args.address is not None and (not args.address or not args.address.isprintable()):
        p.error(f"argument --address: must be a printable address, got {args.address!r}")
    options = SweepOptions(backend=args.backend, workers=args.workers, address=args.address,
                           resume=args.resume)
    try:
        result = run_sweep(args.sweep, out=args.out, options=options)
    except SweepInterrupted as stop:
        terminated = isinstance(stop.by, Terminated)
        print(f"cell sweep: {'terminated' if terminated else 'interrupted'}: {stop.done} of "
              f"{stop.total} runs are in {escape(str(stop.path))}; run the same command with "
              "--resume to do the rest", file=sys.stderr)
        return 143 if terminated else 130
    out = escape(str(result.out))
    earlier = (f"; {result.failed_before} of the resumed had failed, not run again: their rows "
               "say why" if result.failed_before else "")
    print(f"sweep {escape(repr(args.sweep))}: {result.total} runs ({result.resumed} resumed, "
          f"{result.ran} run now, {result.failed} failed{earlier}) in {clock(result.wall_s)}")
    if result.cut_bytes:
        print(f"  dropped a half-written last row ({result.cut_bytes} bytes) of an interrupted "
              "session; that run was done again")
    print(f"  wrote results.csv{''.join(' ' + f for f in result.files)} to {out}/")
    return 0
