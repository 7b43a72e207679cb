"""The matching study's report: hit rate and peak error of SSD, SAD, NCC and ORB under a
brightness change, a contrast change and a turn of the part.

Plot ``matching.png``: one column per change (brightness offset, contrast factor, turn in
degrees), the hit rate (top) and the median peak error of the hits in pixels (bottom),
one line per method (means over the seeds and parts; the unchanged frame is the point at
brightness 0, contrast 1 and a turn of 0).
"""

from __future__ import annotations

from cell.sweep.reports.table import Plot, Report, done, figure, markdown, mean, number, png, values

__all__ = ["CHANGES", "PLOTS", "build"]

PLOTS = ("matching.png",)  # the plots it writes (checked before the runs)

CHANGES = (("job.brightness", "brightness (grey levels added)", 0.0),
           ("job.contrast", "contrast (grey levels times)", 1.0),
           ("job.rotation_deg", "turn of the part (deg)", 0.0))


def _unchanged(row: dict) -> bool:
    return all((row.get(k) if row.get(k) is not None else neutral) == neutral for k, _, neutral in CHANGES)


def _along(rows: list[dict], key: str) -> list[dict]:
    """The rows that change only ``key`` (and the unchanged ones)."""
    return [r for r in rows if all((r.get(k) if r.get(k) is not None else n) == n
                                   for k, _, n in CHANGES if k != key)]


def _limit(rows: list[dict], key: str, method: str, neutral: float, side: int) -> float | None:
    """The furthest value of ``key`` on one side (``side`` -1 or +1) of ``neutral`` up to
    which the method's hit rate stays at least 90 % (None: not even the first step)."""
    mine = [r for r in rows if r.get("job.method") == method]
    xs = [x for x in values(mine, key) if (x - neutral) * side > 0]
    xs.sort(key=lambda x: abs(x - neutral))
    reach = None
    for x in xs:
        if (mean([r for r in mine if r.get(key) == x], "hit_rate") or 0) < 0.9:
            break
        reach = x
    return reach


def build(rows: list[dict], plan) -> Report:
    rows = [r for r in done(rows) if r.get("job") == "match"]
    if not rows:
        return Report(("No run finished.",), (), ())
    methods = values(rows, "job.method")
    fig, axes = figure(2, len(CHANGES), size=(13.0, 7.0))
    heads, body = [], []
    for j, (key, name, neutral) in enumerate(CHANGES):
        along = _along(rows, key)
        for method in methods:
            mine = [r for r in along if r.get("job.method") == method]
            xs = sorted({r.get(key) if r.get(key) is not None else neutral for r in mine})
            for i, metric in enumerate(("hit_rate", "peak_error_px_median")):
                ys = [mean([r for r in mine if (r.get(key) if r.get(key) is not None else neutral) == x],
                           metric) for x in xs]
                axes[i, j].plot(xs, [y if y is not None else float("nan") for y in ys], marker="o",
                                markersize=3, label=method)
        axes[0, j].set_title(name, fontsize=9)
        axes[0, j].set_ylim(-0.02, 1.05)
        axes[0, j].set_ylabel("hit rate")
        axes[1, j].set_ylabel("peak error of the hits, median (px)")
        for i in range(2):
            axes[i, j].set_xlabel(name)
            axes[i, j].grid(alpha=0.3)
        axes[0, j].legend(fontsize=7)
    base = [r for r in rows if _unchanged(r)]
    for method in methods:
        mine = [r for r in base if r.get("job.method") == method]
        if not mine:  # the ranges are measured from the unchanged frame
            heads.append(f"{method}: no run on the unchanged frame in this grid (brightness +0, "
                         "contrast x1, no turn), which its ranges are measured from")
            body.append([method, "-", "-", "-", "-", "-", "-", "-"])
            continue
        hits = mean(mine, "hit_rate")
        spans = {}
        for key, _, neutral in CHANGES:
            along = _along(rows, key)
            lo, hi = _limit(along, key, method, neutral, -1), _limit(along, key, method, neutral, 1)
            spans[key] = (neutral if lo is None else lo, neutral if hi is None else hi)
        turns = [r for r in _along(rows, "job.rotation_deg") if r.get("job.method") == method]
        widest = max(values(turns, "job.rotation_deg"), default=None)
        at_widest = mean([r for r in turns if r.get("job.rotation_deg") == widest], "hit_rate")
        (b0, b1), (c0, c1), (_, t1) = (spans[k] for k, _, _ in CHANGES)
        text = (f"{method}: {number(hits, '.0%')} hits on the unchanged frame (peak error "
                f"{number(mean(mine, 'peak_error_px_median'), '.2f')} px)")
        if (hits or 0) >= 0.9:
            text += (f"; >= 90 % hits for brightness {b0:+g} to {b1:+g}, contrast x{c0:g} to x{c1:g} "
                     f"and turns up to {t1:g} deg")
        else:
            text += "; never >= 90 % hits"
        if widest is not None:
            text += f"; at a {widest:g} deg turn {number(at_widest, '.0%')}"
        heads.append(text)
        ok = (hits or 0) >= 0.9
        body.append([method, number(hits, ".0%"), number(mean(mine, "peak_error_px_median"), ".2f"),
                     f"{b0:+g} .. {b1:+g}" if ok else "-", f"x{c0:g} .. x{c1:g}" if ok else "-",
                     f"{t1:g}" if ok else "-", number(at_widest, ".0%"),
                     number(mean(mine, "match_ms"), ".0f")])
    fig.suptitle("Template matching: hit rate (a peak within job.hit_px of the truth) and peak error, "
                 "per change of the searched frame", fontsize=9)
    table = markdown(["method", "hits (unchanged)", "peak error px", "brightness with >= 90 % hits",
                      "contrast with >= 90 % hits", "turn with >= 90 % hits (deg)", "hits at the widest turn",
                      "ms per frame"], body)
    plot = Plot(PLOTS[0], "hit rate and peak error of SSD, SAD, NCC and ORB against brightness, "
                "contrast and rotation", png(fig))
    return Report(tuple(heads), (plot,), (table,))
