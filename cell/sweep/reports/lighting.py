"""The lighting study's report: the detector's and the sort job's figures per light.

A light is a preset, or presets combined (``capture.presets``: ``back+front``). Plot
``lighting.png``: grouped bars per light of the detector's parts found, kind and material
accuracy and the sort job's sort accuracy (top), and the position errors (bottom: the
detector's mean per frame, the sort job's p95), means over the seeds.
"""

from __future__ import annotations

from cell.catalogue import LIGHTING_PRESETS
from cell.sweep.reports.table import Plot, Report, done, figure, markdown, mean, number, png

__all__ = ["PLOTS", "build", "light"]

PLOTS = ("lighting.png",)  # the plots it writes (checked before the runs)

_BARS = (("detect", "recall", "parts found"), ("detect", "kind_accuracy", "kind right"),
         ("detect", "material_accuracy", "material right"), ("sort", "sort_accuracy", "sort accuracy"))


def light(row: dict) -> str:
    """The light of a row: its capture presets joined by ``+``, else its lighting preset."""
    presets = row.get("capture.presets")
    return "+".join(presets) if presets else str(row.get("lighting"))


def _order(names: set[str]) -> list[str]:
    first = [p for p in LIGHTING_PRESETS if p in names]
    return first + sorted(names - set(first))


def _share(by: dict, job: str, metric: str, li: str) -> float | str:
    """The mean of ``metric`` of ``job`` under light ``li``, or why there is none: ``no run``,
    ``no value``, or ``unknown`` for the material where most parts were called unknown (a
    silhouette under a back light: no material to be right about)."""
    rows = by.get((job, li))
    if not rows:
        return "no run"
    if metric == "material_accuracy" and (mean(rows, "material_unknown") or 0) > 0.5:
        return "unknown"
    value = mean(rows, metric)
    return "no value" if value is None else float(value)


def _figure(lights: list[str], by: dict) -> bytes:
    import numpy as np

    fig, axes = figure(2, 1, size=(10.0, 6.5))
    ax = axes[0, 0]
    width = 0.8 / len(_BARS)
    x = np.arange(len(lights))
    for k, (job, metric, name) in enumerate(_BARS):
        ys = [_share(by, job, metric, li) for li in lights]
        at = x + (k - (len(_BARS) - 1) / 2) * width
        ax.bar(at, [y if isinstance(y, float) else float("nan") for y in ys], width, label=name)
        for xi, y in zip(at, ys, strict=True):  # no bar is not a bar of 0: say why
            if not isinstance(y, float):
                ax.text(xi, 0.02, y, rotation=90, ha="center", va="bottom", fontsize=6)
    ax.set_xticks(x, lights)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("share (mean over seeds)")
    ax.legend(fontsize=8, ncol=4, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    ax.grid(axis="y", alpha=0.3)
    ax = axes[1, 0]
    for k, (job, metric, name) in enumerate((("detect", "position_error_mm_mean", "detector: mean per frame"),
                                             ("sort", "position_error_mm_p95", "sort job: p95"))):
        ys = [mean(by[(job, li)], metric) if (job, li) in by else None for li in lights]
        ax.bar(x + (k - 0.5) * 0.4, [y if y is not None else float("nan") for y in ys], 0.4,
               label=name)
    ax.set_xticks(x, lights)
    ax.set_ylabel("position error (mm)")
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.suptitle("Detector and sort job per light (back+front: outline from the back light, "
                 "material from the front light)", fontsize=9)
    return png(fig)


def _material(by: dict, li: str) -> str:
    """The table's material cell: as the plot says it (``unknown`` under a back light)."""
    share = _share(by, "detect", "material_accuracy", li)
    return number(share, ".0%") if isinstance(share, float) else "-" if share != "unknown" else share


def build(rows: list[dict], plan) -> Report:
    failed = {light(r) for r in rows if r.get("error")} - {light(r) for r in done(rows)}
    rows = done(rows)
    if not rows:
        return Report(("No run finished.",), (), ())
    by: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        by.setdefault((str(r.get("job")), light(r)), []).append(r)
    lights = _order({li for _, li in by} | failed)  # (a light whose every run failed: a row)
    body, heads = [], [f"{li}: every run failed (see below)" for li in _order(failed)]
    for li in lights:
        d, s = by.get(("detect", li), []), by.get(("sort", li), [])
        body.append([li, number(mean(d, "recall"), ".0%"), number(mean(d, "kind_accuracy"), ".0%"),
                     _material(by, li),
                     number(mean(d, "position_error_mm_mean"), ".2f"),
                     number(mean(s, "sort_accuracy"), ".0%"),
                     number(mean(s, "classification_accuracy"), ".0%"),
                     number(mean(s, "rejected"), ".1f"), number(mean(s, "position_error_mm_p95"), ".2f")])
    detect_rank = sorted((li for li in lights if ("detect", li) in by),
                         key=lambda li: (mean(by[("detect", li)], "recall") or 0,
                                         mean(by[("detect", li)], "material_accuracy") or 0), reverse=True)
    if len(detect_rank) == 1:  # (one light is no ranking)
        li = detect_rank[0]
        heads.append(f"detector: {number(mean(by[('detect', li)], 'recall'), '.0%')} of the parts "
                     f"found under {li}, the only light with a finished detect run")
    elif detect_rank:
        best, worst = detect_rank[0], detect_rank[-1]
        found = {li: number(mean(by[("detect", li)], "recall"), ".0%") for li in detect_rank}
        if found[best] == found[worst]:  # (as printed: a tie is no ranking)
            heads.append(f"detector: the same share of parts found under every light ({found[best]})")
        else:
            heads.append(f"detector: most parts found under {best} ({found[best]}), fewest under "
                         f"{worst} ({found[worst]})")
    placed = [li for li in lights if mean(by.get(("detect", li), []), "position_error_mm_mean") is not None]
    if len(placed) > 1:
        err = {li: mean(by[("detect", li)], "position_error_mm_mean") for li in placed}
        lo, hi = min(placed, key=err.get), max(placed, key=err.get)
        heads.append(f"detector position: most precise under {lo} ({err[lo]:.2f} mm mean), least "
                     f"under {hi} ({err[hi]:.2f} mm)")
    for li in lights:
        d = by.get(("detect", li), [])
        if d and (mean(d, "material_unknown") or 0) > 0.5:
            heads.append(f"{li}: the material is unknown for {mean(d, 'material_unknown'):.0%} of the "
                         "parts (a silhouette has no colour or grain)")
    for li in [li for li in lights if ("sort", li) in by]:
        s = by[("sort", li)]
        heads.append(f"sort job under {li}: sort accuracy {number(mean(s, 'sort_accuracy'), '.0%')}, "
                     f"{number(mean(s, 'rejected'), '.1f')} parts rejected per run, position p95 "
                     f"{number(mean(s, 'position_error_mm_p95'), '.2f')} mm")
    table = markdown(["light", "found", "kind", "material", "position mm (mean)", "sort accuracy",
                      "classification", "rejected / run", "sort position p95 mm"], body)
    plot = Plot(PLOTS[0], "detector and sort-job figures per light", _figure(lights, by))
    return Report(tuple(heads), (plot,), (table,))
