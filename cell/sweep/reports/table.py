"""Small helpers the study reports share: grouping rows, means, labels, Markdown tables,
and a matplotlib figure turned into PNG bytes (Agg, no display needed).

Rows are the dicts of :func:`cell.sweep.results.read_rows`; a failed run (``error`` set)
has no figures, and a figure with no samples is ``None``: means skip both, and a mean of
nothing is ``None`` (shown ``-``), never NaN.
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

__all__ = ["Plot", "Report", "done", "figure", "group", "label", "markdown", "mean", "number",
           "png", "values"]


@dataclass(frozen=True)
class Plot:
    """A plot of the report: its ``file`` name (``*.png``), ``caption`` and ``png`` bytes."""

    file: str
    caption: str
    png: bytes


@dataclass(frozen=True)
class Report:
    """What a study report says: ``headlines`` (one finding each, with its figures),
    ``plots`` and ``tables`` (Markdown)."""

    headlines: tuple[str, ...]
    plots: tuple[Plot, ...]
    tables: tuple[str, ...]


def done(rows: Iterable[dict]) -> list[dict]:
    """The rows of runs that did not fail."""
    return [r for r in rows if not r.get("error")]


def values(rows: Iterable[dict], key: str) -> list[Any]:
    """The distinct values of ``key`` (None left out), numbers sorted, others in order."""
    seen = list(dict.fromkeys(r.get(key) for r in rows if r.get(key) is not None))
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in seen):
        return sorted(seen)
    return seen


def group(rows: Iterable[dict], *keys: str) -> dict[tuple, list[dict]]:
    """Rows by their values of ``keys``, in order of first appearance."""
    out: dict[tuple, list[dict]] = {}
    for r in rows:
        out.setdefault(tuple(r.get(k) for k in keys), []).append(r)
    return out


def mean(rows: Iterable[dict], key: str, fn: Callable[[list[float]], float] | None = None) -> float | None:
    """The mean (or ``fn``) of ``key`` over the rows that have it; None if none do."""
    xs = [float(r[key]) for r in rows if isinstance(r.get(key), (int, float))
          and not isinstance(r.get(key), bool) and math.isfinite(float(r[key]))]
    if not xs:
        return None
    return float(fn(xs)) if fn else sum(xs) / len(xs)


def number(value: float | None, spec: str = ".2f", *, scale: float = 1.0, unit: str = "") -> str:
    """``value`` formatted (times ``scale``, with ``unit``), or ``-`` when None."""
    if value is None or not math.isfinite(value):
        return "-"
    return format(value * scale, spec) + unit


def label(value: Any) -> str:
    """A parameter value as a short label."""
    if isinstance(value, tuple):
        return "+".join(str(v) for v in value) if all(isinstance(v, str) for v in value) else str(list(value))
    if isinstance(value, float):
        return f"{value:g}"
    return "-" if value is None else str(value)


def markdown(header: list[str], body: list[list[str]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in body]
    return "\n".join(lines)


def figure(nrows: int = 1, ncols: int = 1, *, size: tuple[float, float] = (7.0, 4.2)):
    """A new matplotlib figure and its axes: a ``Figure`` of its own, outside pyplot, so
    the caller's backend and open figures are left as they were (a notebook's inline
    plots: ``matplotlib.use("Agg")`` switched them off)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=size)
    return fig, fig.subplots(nrows, ncols, squeeze=False)


def png(fig) -> bytes:
    """The figure as PNG bytes (100 dpi; the Agg renderer, whatever the backend)."""
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    return buf.getvalue()
