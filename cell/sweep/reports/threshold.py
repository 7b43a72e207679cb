"""The threshold study's report: where a fixed grey level works under each light, against
Otsu, iterative, adaptive and the belt model; and the sort job at a few settings.

Plot ``threshold.png``: two heat maps, rows the lighting presets, columns the fixed
thresholds and then the four methods: the share of parts found (recall) and the
foreground IoU on the belt. Each row's *band* (a black frame) holds the fixed thresholds
that find at least 90 % as many parts as that row's best fixed threshold; left of it the
threshold is too low (the belt itself passes it), right of it too high (the darker parts
fall under it); a dashed line marks the syllabus's 150.
"""

from __future__ import annotations

from cell.catalogue import LIGHTING_PRESETS
from cell.sweep.reports.plots import heatmap, matrix
from cell.sweep.reports.table import Plot, Report, done, figure, group, markdown, mean, number, png, values

__all__ = ["METHODS", "PLOTS", "SYLLABUS", "band", "build"]

PLOTS = ("threshold.png",)  # the plots it writes (checked before the runs)

METHODS = ("otsu", "iterative", "adaptive", "belt")
SYLLABUS = 150
_BAND = 0.9


def band(recalls: list[float | None]) -> tuple[int, int] | None:
    """First and last index of the contiguous run around the best recall where the recall
    is at least 90 % of it; None if nothing is found anywhere."""
    known = [(v if v is not None else -1.0) for v in recalls]
    best = max(known, default=-1.0)
    if best <= 0:
        return None
    i = known.index(best)
    lo = hi = i
    while lo > 0 and known[lo - 1] >= _BAND * best:
        lo -= 1
    while hi < len(known) - 1 and known[hi + 1] >= _BAND * best:
        hi += 1
    return lo, hi


def _x(row: dict):
    seg = row.get("vision.segmentation")
    return row.get("vision.threshold") if seg == "fixed" else seg


def _figure(det: list[dict], presets: list, columns: list, n_fixed: int, bands: dict) -> bytes:
    from matplotlib.patches import Rectangle

    fig, axes = figure(2, 1, size=(11.0, 7.5))
    for ax, metric, title in ((axes[0, 0], "recall", "parts found (share of the parts in view)"),
                              (axes[1, 0], "fg_iou", "foreground IoU with the true parts, on the belt")):
        values_ = matrix(det, metric, presets, columns, lambda r: r.get("lighting"), _x)
        heatmap(ax, values_, columns, presets, title=title)
        ax.axvline(n_fixed - 0.5, color="black", lw=2)
        if SYLLABUS in columns:
            at = columns.index(SYLLABUS)
            ax.axvline(at, color="blue", ls="--", lw=1.2)
            ticks = [t.get_text() for t in ax.get_xticklabels()]
            ticks[at] = "150 (syllabus)"
            ax.set_xticks(range(len(columns)), ticks, rotation=60, fontsize=7)
        for i, p in enumerate(presets):
            b = bands.get(p)
            if b is not None:
                ax.add_patch(Rectangle((b[0] - 0.5, i - 0.5), b[1] - b[0] + 1, 1, fill=False, lw=1.6,
                                       edgecolor="black"))
        ax.set_xlabel("fixed threshold (grey level)  |  methods")
    fig.suptitle("Fixed threshold vs. textbook methods per light. Framed: the fixed levels within 90 % "
                 "of the row's best recall;\nleft of the frame too low (the belt passes), right of it "
                 "too high (the darker parts are lost)", fontsize=9)
    return png(fig)


def _span(thresholds: list, b: tuple[int, int] | None) -> str:
    if b is None:
        return "-"
    return f"{thresholds[b[0]]}" if b[0] == b[1] else f"{thresholds[b[0]]}-{thresholds[b[1]]}"


def _preset_line(p: str, thresholds: list, recalls: list, b: tuple[int, int] | None, at150) -> str:
    if b is None:
        return f"{p}: no fixed threshold finds a part"
    lo_zero = [t for t, r in zip(thresholds[: b[0]], recalls[: b[0]], strict=True) if r == 0]
    hi_zero = [t for t, r in zip(thresholds[b[1] + 1:], recalls[b[1] + 1:], strict=True) if r == 0]
    best = max(r for r in recalls if r is not None)
    text = f"{p}: a fixed threshold of {_span(thresholds, b)} works best (finds {best:.0%} of the parts)"
    if lo_zero:
        text += f"; at {lo_zero[-1]} and below it finds none (the belt passes)"
    if hi_zero:
        text += f", at {hi_zero[0]} and above none"
    if at150 is not None:
        text += f"; the syllabus's 150 finds {at150:.0%}"
    return text


def build(rows: list[dict], plan) -> Report:
    rows = done(rows)
    det = [r for r in rows if r.get("job") == "detect"]
    sort = [r for r in rows if r.get("job") == "sort"]
    presets = [p for p in LIGHTING_PRESETS if p in values(det, "lighting")]
    fixed = [r for r in det if r.get("vision.segmentation") == "fixed"]
    thresholds = values(fixed, "vision.threshold")
    methods = [m for m in METHODS if any(r.get("vision.segmentation") == m for r in det)]
    columns = thresholds + methods
    if not det:  # (the sort runs still have their table)
        heads, tables = _sort_figures(sort)
        return Report(("No detect run finished.", *heads), (), tables)
    recall = matrix(det, "recall", presets, columns, lambda r: r.get("lighting"), _x)
    iou = matrix(det, "fg_iou", presets, columns, lambda r: r.get("lighting"), _x)
    bands = {p: band(recall[i][: len(thresholds)]) for i, p in enumerate(presets)}
    heads, body = [], []
    for i, p in enumerate(presets):
        fixed_r = recall[i][: len(thresholds)]
        at150 = fixed_r[thresholds.index(SYLLABUS)] if SYLLABUS in thresholds else None
        heads.append(_preset_line(p, thresholds, fixed_r, bands[p], at150))
        b = bands[p]
        body.append([p, _span(thresholds, b), number(at150, ".0%")]
                    + [f"{number(recall[i][len(thresholds) + j], '.0%')} / "
                       f"{number(iou[i][len(thresholds) + j], '.2f')}" for j in range(len(methods))])
    for j, m in enumerate(methods):
        col = [recall[i][len(thresholds) + j] for i in range(len(presets))]
        known = [v for v in col if v is not None]
        if known and f"{min(known):.0%}" == f"{max(known):.0%}":  # (as printed: no worst)
            heads.append(f"{m}: finds {min(known):.0%} of the parts under each of the "
                         f"{len(known)} presets")
        elif known:
            worst = presets[col.index(min(known))]
            heads.append(f"{m}: finds {min(known):.0%} to {max(known):.0%} of the parts over the "
                         f"{len(known)} presets (worst under {worst})")
    sort_heads, sort_tables = _sort_figures(sort)
    tables = (markdown(["preset", "fixed band", "fixed 150"] + [f"{m} found / IoU" for m in methods],
                       body), *sort_tables)
    plot = Plot(PLOTS[0], "parts found and foreground IoU per light: fixed thresholds 0-255 "
                "and the four methods", _figure(det, presets, columns, len(thresholds), bands))
    return Report((*heads, *sort_heads), (plot,), tables)


def _sort_figures(sort: list[dict]) -> tuple[list[str], tuple[str, ...]]:
    """Headlines and the table of the sort job's rows, per light and segmentation."""
    if not sort:
        return [], ()
    heads, body = [], []
    cells = group(sort, "lighting", "vision.segmentation", "vision.threshold")
    for (light, seg, t), members in cells.items():
        name = f"fixed {t}" if seg == "fixed" else seg
        body.append([str(light), name, number(mean(members, "sort_accuracy"), ".0%"),
                     number(mean(members, "classification_accuracy"), ".0%"),
                     number(mean(members, "rejected"), ".1f"), number(mean(members, "missed"), ".1f")])
        heads.append(f"sort job, {light}, {name}: sort accuracy "
                     f"{number(mean(members, 'sort_accuracy'), '.0%')}")
    return heads, (markdown(["light", "segmentation", "sort accuracy", "classification", "rejected",
                             "missed"], body),)
