"""The report of any sweep: each metric's mean over the seeds against the grid's axes.

The x axis is the first parameter that varies and takes numbers (else the first that
varies); each other combination of varying parameters is one line (at most eight shown);
one panel per metric that changes between runs (at most six; a count that is the same in
every run, such as the parts per scene, says nothing). The headline names, for the first
of them, the setting with the highest and the lowest mean.
"""

from __future__ import annotations

from cell.sweep.reports.table import (
    Plot,
    Report,
    done,
    figure,
    group,
    label,
    markdown,
    mean,
    number,
    png,
    values,
)

__all__ = ["PLOTS", "build", "overview", "varying"]

PLOTS = ("metrics.png",)  # the plots it writes (checked before the runs)

_PANELS = 6
_LINES = 8


def varying(rows: list[dict], params: tuple[str, ...]) -> list[str]:
    """The parameters that take more than one value in ``rows``."""
    return [p for p in params if len(values(rows, p)) > 1]


def build(rows: list[dict], plan) -> Report:
    """The generic report of ``plan``'s rows."""
    return overview(rows, plan.columns.params, plan.columns.metrics)


def overview(rows: list[dict], params: tuple[str, ...], metrics: tuple[str, ...], *,
             file: str = PLOTS[0]) -> Report:
    """Each metric of ``metrics`` against the parameters of ``params`` that vary."""
    rows = done(rows)
    keys = varying(rows, params)
    measured = [m for m in metrics if mean(rows, m) is not None]
    shown = ([m for m in measured if len(values(rows, m)) > 1] or measured)[:_PANELS]
    if not rows or not shown:
        return Report(("No run produced figures.",), (), ())
    numeric = [k for k in keys if all(isinstance(v, (int, float)) for v in values(rows, k))]
    x = (numeric or keys or [None])[0]
    others = [k for k in keys if k != x]
    fig, axes = figure(len(shown), 1, size=(7.0, 2.6 * len(shown)))
    ticks = values(rows, x) if x else [0]  # every line's points at these positions
    for ax, metric in zip(axes[:, 0], shown, strict=True):
        for combo, members in list(group(rows, *others).items())[:_LINES]:
            xs = values(members, x) if x else [0]
            ys = [mean([r for r in members if x is None or r.get(x) == v], metric) for v in xs]
            name = ", ".join(f"{k}={label(v)}" for k, v in zip(others, combo, strict=True)) or None
            ax.plot([ticks.index(v) for v in xs] if x not in numeric else xs,
                    [y if y is not None else float("nan") for y in ys], marker="o", label=name)
        if x not in numeric and x is not None:
            ax.set_xticks(range(len(ticks)), [label(v) for v in ticks], rotation=30)
        ax.set_ylabel(metric)
        ax.set_xlabel(x or "")
        if others:
            ax.legend(fontsize=7)
    table_rows = []
    by_point = group(rows, *keys)
    for combo, members in by_point.items():
        table_rows.append([label(v) for v in combo] + [number(mean(members, m), ".3g") for m in shown])
    first = shown[0]
    ranked = sorted(((mean(m, first), c) for c, m in by_point.items() if mean(m, first) is not None),
                    key=lambda t: t[0])
    head = ()
    if ranked and keys:
        (lo, lo_c), (hi, hi_c) = ranked[0], ranked[-1]
        text = lambda c: ", ".join(f"{k}={label(v)}" for k, v in zip(keys, c, strict=True))  # noqa: E731
        head = (f"{first}: highest {number(hi, '.3g')} at {text(hi_c)}; lowest {number(lo, '.3g')} "
                f"at {text(lo_c)} (mean over seeds).",)
        if number(hi, ".3g") == number(lo, ".3g"):
            head = (f"{first}: {number(hi, '.3g')} at every setting (mean over seeds).",)
    return Report(head, (Plot(file, "each metric against the grid", png(fig)),),
                  (markdown(keys + shown, table_rows),))
