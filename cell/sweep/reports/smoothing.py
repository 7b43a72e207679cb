"""The smoothing study's report: filter passes against noise, by IoU and position error.

Plot ``smoothing.png``: the foreground IoU (left) and the detector's mean position error
(right) against the passes of the filter, for Gaussian noise (top) and salt and pepper
(bottom), one colour per noise level, solid the 3x3 Gaussian, dashed the median (means
over the seeds; 0 passes is the unfiltered frame).
"""

from __future__ import annotations

from cell.sweep.reports.table import Plot, Report, done, figure, markdown, mean, number, png, values

__all__ = ["PLOTS", "build", "noise"]

PLOTS = ("smoothing.png",)  # the plots it writes (checked before the runs)


def noise(row: dict) -> tuple[str, float]:
    """A row's noise: ("salt & pepper", share) when it has any, else ("gaussian", sigma)."""
    sp = row.get("sensor.salt_pepper") or 0.0
    return ("salt & pepper", sp) if sp > 0 else ("gaussian", float(row.get("sensor.noise_std") or 0.0))


def _cell(rows: list[dict], kind: str, level: float, filt: str, n: int) -> list[dict]:
    return [r for r in rows if noise(r) == (kind, level) and r.get("job.iterations") == n
            and (n == 0 or r.get("job.filter") == filt)]


def build(rows: list[dict], plan) -> Report:
    rows = [r for r in done(rows) if r.get("job") == "smooth"]
    if not rows:
        return Report(("No run finished.",), (), ())
    passes = values(rows, "job.iterations")
    filters = values(rows, "job.filter")
    kinds = [k for k in ("gaussian", "salt & pepper") if any(noise(r)[0] == k for r in rows)]
    sizes = values(rows, "job.ksize")
    size = f" {sizes[0]}x{sizes[0]}" if len(sizes) == 1 else ""
    styles = ", ".join(f"{style}: {filt}{size}"  # (the line styles, in the order drawn)
                       for filt, style in zip(filters, ("solid", "dashed", "dotted"), strict=False))
    fig, axes = figure(len(kinds), 2, size=(11.0, 3.8 * len(kinds)))
    heads, body = [], []
    for i, kind in enumerate(kinds):
        levels = sorted({noise(r)[1] for r in rows if noise(r)[0] == kind})
        for j, (metric, name) in enumerate((("fg_iou", "foreground IoU"),
                                            ("position_error_mm_mean", "position error, mean (mm)"))):
            ax = axes[i, j]
            for k, level in enumerate(levels):
                colour = f"C{k}"
                for filt, ls in zip(filters, ("-", "--", ":"), strict=False):
                    ys = [mean(_cell(rows, kind, level, filt, n), metric) for n in passes]
                    ax.plot(passes, [y if y is not None else float("nan") for y in ys], ls=ls, marker="o",
                            markersize=3, color=colour, label=f"{level:g} {filt}")
            ax.set_xlabel(f"filter passes ({styles})")
            ax.set_ylabel(name)
            unit = "sigma, grey levels" if kind == "gaussian" else "share of pixels"
            ax.set_title(f"{kind} noise ({unit})", fontsize=9)
            ax.grid(alpha=0.3)
            if j == 0:
                ax.legend(fontsize=6, ncol=2)
        for level in levels:
            raw = mean(_cell(rows, kind, level, filters[0], 0), "fg_iou")
            pos_raw = mean(_cell(rows, kind, level, filters[0], 0), "position_error_mm_mean")
            parts = [f"{kind} noise {level:g}: unfiltered IoU {number(raw, '.2f')}, position "
                     f"{number(pos_raw, '.2f')} mm"]
            for f in filters:
                body.append([kind, f"{level:g}", f] + [
                    f"{number(mean(_cell(rows, kind, level, f, n), 'fg_iou'), '.2f')} / "
                    f"{number(mean(_cell(rows, kind, level, f, n), 'position_error_mm_mean'), '.2f')}"
                    for n in passes])
                scored = [(mean(_cell(rows, kind, level, f, n), "fg_iou"), n) for n in passes]
                scored = [(v, n) for v, n in scored if v is not None]
                if scored:
                    v, n = max(scored, key=lambda t: (t[0], -t[1]))
                    pos = mean(_cell(rows, kind, level, f, n), "position_error_mm_mean")
                    parts.append(f"best {f}: {'no pass' if n == 0 else f'{n} pass(es)'} (IoU {v:.2f}, "
                                 f"position {number(pos, '.2f')} mm)")
            heads.append("; ".join(parts))
    table = markdown(["noise", "level", "filter"] + [f"{n} passes: IoU / mm" for n in passes], body)
    plot = Plot(PLOTS[0], "foreground IoU and position error against filter passes, per noise",
                png(fig))
    return Report(tuple(heads), (plot,), (table,))
