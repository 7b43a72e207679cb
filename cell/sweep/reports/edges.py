"""The edges study's report: Canny's thresholds against closed outlines and clutter.

Plot ``edges.png``: per light (rows), heat maps over the high threshold (columns) and the
low threshold's share of it (rows of each map) of the share of part outlines that close
and of the clutter (the share of edge pixels on no true outline), means over the seeds.
"""

from __future__ import annotations

from dataclasses import dataclass

from cell.catalogue import LIGHTING_PRESETS
from cell.sweep.reports.plots import Colours, heatmap, matrix
from cell.sweep.reports.table import Plot, Report, done, figure, markdown, number, png, values

__all__ = ["PLOTS", "build"]

PLOTS = ("edges.png",)  # the plots it writes (checked before the runs)

_CLUTTER = 0.1  # at most this share of clutter counts as clean


@dataclass(frozen=True)
class _Cell:
    """One setting's means: the share of outlines ``closed``, the ``clutter`` share (None
    when no edge pixel was found), Canny's ``high`` threshold and ``low`` = ``ratio`` x
    ``high``."""

    closed: float
    clutter: float | None
    ratio: float
    high: float

    @property
    def low(self) -> float:
        return self.ratio * self.high


def build(rows: list[dict], plan) -> Report:
    rows = [r for r in done(rows) if r.get("job") == "edges"]
    if not rows:
        return Report(("No run finished.",), (), ())
    lights = [p for p in LIGHTING_PRESETS if p in values(rows, "lighting")] or [None]
    highs, ratios = values(rows, "job.high"), values(rows, "job.low_ratio")
    fig, axes = figure(len(lights), 2, size=(12.0, 3.6 * len(lights)))
    heads, body = [], []
    for i, li in enumerate(lights):
        mine = [r for r in rows if r.get("lighting") == li]
        closed = matrix(mine, "outline_closed", ratios, highs, lambda r: r.get("job.low_ratio"),
                        lambda r: r.get("job.high"))
        clutter = matrix(mine, "clutter", ratios, highs, lambda r: r.get("job.low_ratio"),
                         lambda r: r.get("job.high"))
        heatmap(axes[i, 0], closed, highs, ratios, title=f"{li}: part outlines closed")
        heatmap(axes[i, 1], clutter, highs, ratios, title=f"{li}: clutter (edge pixels on no outline)",
                colours=Colours(vmax=0.5, cmap="RdYlGn_r"))
        for ax in axes[i]:
            ax.set_xlabel("Canny high threshold (raw 3x3 Sobel magnitude)")
            ax.set_ylabel("low / high")
        cells = [_Cell(closed[a][b], clutter[a][b], ratios[a], highs[b]) for a in range(len(ratios))
                 for b in range(len(highs)) if closed[a][b] is not None]
        clean = [c for c in cells if c.clutter is not None and c.clutter <= _CLUTTER]
        if clean:
            best = max(clean, key=lambda c: (c.closed, -c.clutter))
            heads.append(f"{li}: most outlines closed with at most {_CLUTTER:.0%} clutter at high "
                         f"{best.high:g}, low {best.low:g} (x{best.ratio:g}): {best.closed:.0%} "
                         f"closed, {best.clutter:.0%} clutter")
        if len(cells) > 1:  # (the two ends of one setting are no range)
            most = max(cells, key=lambda c: c.closed)
            low_end = min(cells, key=lambda c: c.low)
            high_end = max(cells, key=lambda c: c.low)
            heads.append(f"{li}: too low (high {low_end.high:g}, low {low_end.low:g}): "
                         f"{number(low_end.clutter, '.0%')} of the edges are clutter; too high (high "
                         f"{high_end.high:g}, low {high_end.low:g}): {number(high_end.closed, '.0%')} "
                         f"of the outlines close; the most that close anywhere: {most.closed:.0%}")
        for a, ratio in enumerate(ratios):
            body.append([str(li), f"{ratio:g}"] + [f"{number(closed[a][b], '.0%')} / "
                                                   f"{number(clutter[a][b], '.0%')}"
                                                   for b in range(len(highs))])
    table = markdown(["light", "low / high"] + [f"high {h:g}: closed / clutter" for h in highs], body)
    plot = Plot(PLOTS[0], "closed outlines and clutter over Canny's high and low thresholds", png(fig))
    return Report(tuple(heads), (plot,), (table,))
