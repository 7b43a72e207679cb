"""Plot pieces the study reports share: a heat map of a metric over two parameters and
lines of a metric against one parameter, both from the mean over the seeds.

Cells and points with no value (no run, or no samples) are left blank, never drawn as 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from cell.sweep.reports.table import label, mean

__all__ = ["ERRORS", "SHARES", "Colours", "heatmap", "lines", "matrix"]


@dataclass(frozen=True)
class Colours:
    """How a heat map colours and labels its cells: values from ``vmin`` to ``vmax`` over
    the matplotlib colour map ``cmap``, each written with ``fmt``."""

    vmin: float = 0.0
    vmax: float = 1.0
    fmt: str = "{:.0%}"
    cmap: str = "RdYlGn"


SHARES = Colours()  # a share, 0..1, shown in per cent: more is better (green)
ERRORS = Colours(cmap="RdYlGn_r", fmt="{:.2f}")  # an error: less is better (green)


def matrix(rows: list[dict], metric: str, ys: list, xs: list, y_of, x_of) -> list[list[float | None]]:
    """The mean of ``metric`` per (y, x) cell; ``y_of(row)``, ``x_of(row)`` place a row."""
    cells: dict[tuple, list[dict]] = {}
    for r in rows:
        cells.setdefault((y_of(r), x_of(r)), []).append(r)
    return [[mean(cells.get((y, x), []), metric) for x in xs] for y in ys]


def heatmap(ax, values: list[list[float | None]], xs: list, ys: list, *, title: str,
            colours: Colours = SHARES, annotate: bool = True) -> Any:
    """Draw ``values`` (rows ``ys``, columns ``xs``) on ``ax`` in ``colours``, each cell
    written in it unless ``annotate`` is False or there are over 400; returns the image."""
    import numpy as np

    c = colours
    data = np.array([[math.nan if v is None else v for v in row] for row in values], dtype=float)
    image = ax.imshow(np.ma.masked_invalid(data), vmin=c.vmin, vmax=c.vmax, cmap=c.cmap,
                      aspect="auto")
    ax.set_xticks(range(len(xs)), [label(x) for x in xs], rotation=60, fontsize=7)
    ax.set_yticks(range(len(ys)), [label(y) for y in ys], fontsize=8)
    ax.set_title(title, fontsize=9)
    if annotate and len(xs) * len(ys) <= 400:
        for i, row in enumerate(values):
            for j, v in enumerate(row):
                if v is not None:
                    ax.text(j, i, c.fmt.format(v), ha="center", va="center", fontsize=5.5)
    return image


def lines(ax, rows: list[dict], metric: str, x: str, by: str | tuple[str, ...], *,
          xs: list | None = None, style: dict | None = None, logx: bool = False) -> None:
    """One line per value of ``by`` (a key, or keys): the mean of ``metric`` against ``x``."""
    keys = (by,) if isinstance(by, str) else by
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault(tuple(r.get(k) for k in keys), []).append(r)
    for combo, members in groups.items():
        points = xs if xs is not None else sorted({r.get(x) for r in members if r.get(x) is not None})
        ys = [mean([r for r in members if r.get(x) == v], metric) for v in points]
        shown = [(p, y) for p, y in zip(points, ys, strict=True) if y is not None]
        if shown:
            ax.plot([p for p, _ in shown], [y for _, y in shown], marker="o", markersize=3,
                    label=" ".join(label(c) for c in combo), **(style or {}))
    if logx:
        ax.set_xscale("log")
    ax.set_xlabel(x)
    ax.set_ylabel(metric)
    ax.grid(alpha=0.3)
