"""The study reports: plots and ``summary.md``, regenerated from ``results.csv``.

``REPORTS`` maps a sweep file's ``sweep.report`` to its module; each has
``build(rows, plan) -> Report`` (:class:`~cell.sweep.reports.table.Report`: headlines,
plots, Markdown tables) and ``PLOTS``, the names of the plots it may write.
:func:`write_report` reads ``results.csv`` back, builds the report and writes each plot
and ``summary.md`` whole (temporary file, then rename); :func:`report_files` names them
all, so that the output folder is checked before the runs.
"""

from __future__ import annotations

import importlib

from cell.sweep.errors import SweepError

__all__ = ["REPORTS", "SUMMARY", "report_files", "report_module", "write_report"]

SUMMARY = "summary.md"
REPORTS: dict[str, str] = {
    "generic": "cell.sweep.reports.generic",
    "threshold": "cell.sweep.reports.threshold",
    "lighting": "cell.sweep.reports.lighting",
    "sampling": "cell.sweep.reports.sampling",
    "compression": "cell.sweep.reports.compression",
    "smoothing": "cell.sweep.reports.smoothing",
    "matching": "cell.sweep.reports.matching",
    "edges": "cell.sweep.reports.edges",
}


def report_module(name: str):
    """The report module ``name``; ``SweepError`` listing the reports if there is none."""
    from cell.text import escape

    if name not in REPORTS:
        raise SweepError(f"unknown report {escape(repr(name))}; valid: {', '.join(REPORTS)}")
    return importlib.import_module(REPORTS[name])


def report_files(name: str) -> tuple[str, ...]:
    """The files report ``name`` writes: its plots, then ``summary.md``."""
    return (*report_module(name).PLOTS, SUMMARY)


def write_report(plan, out) -> tuple[str, ...]:
    """Write the plots and ``summary.md`` of ``plan`` into ``out``; the files written."""
    from cell.sweep.reports.summary import write_summary

    return write_summary(plan, out)
