"""The sampling study's report: resolution and bit depth against the detector's figures.

Plot ``sampling.png``: heat maps (rows the resolutions, columns the bits per channel) of
the parts found, the classification accuracy (kind and material both right) and the mean
position error, and the detector's latency against the pixel count at 8 bits (means over
the seeds).
"""

from __future__ import annotations

import dataclasses
import statistics

from cell.sweep.reports.plots import ERRORS, heatmap, matrix
from cell.sweep.reports.table import Plot, Report, done, figure, markdown, mean, number, png, values

__all__ = ["PLOTS", "build"]

PLOTS = ("sampling.png",)  # the plots it writes (checked before the runs)

_GOOD = 0.9


def _res(row: dict) -> str:
    return f"{row.get('camera.width')}x{row.get('camera.height')}"


def _pixels(label: str) -> int:
    w, h = label.split("x")
    return int(w) * int(h)


_FEW = 0.5  # a cell of the per-part maps whose setting finds fewer parts is blank


def _where_found(values: list[list[float | None]], found: list[list[float | None]]
                 ) -> list[list[float | None]]:
    """``values`` with None where fewer than ``_FEW`` of the parts were found: a figure
    averaged over the few parts found is no figure of the setting."""
    return [[v if f is not None and f >= _FEW else None for v, f in zip(vrow, frow, strict=True)]
            for vrow, frow in zip(values, found, strict=True)]


def build(rows: list[dict], plan) -> Report:
    rows = [r for r in done(rows) if r.get("job") == "detect"]
    if not rows:
        return Report(("No run finished.",), (), ())
    resolutions = sorted({_res(r) for r in rows}, key=_pixels)
    bits = values(rows, "sensor.bits")
    found = matrix(rows, "recall", resolutions, bits, _res, lambda r: r.get("sensor.bits"))
    klass = matrix(rows, "classification_accuracy", resolutions, bits, _res, lambda r: r.get("sensor.bits"))
    pos = matrix(rows, "position_error_mm_mean", resolutions, bits, _res, lambda r: r.get("sensor.bits"))
    fig, axes = figure(2, 2, size=(11.0, 7.5))
    heatmap(axes[0, 0], found, bits, resolutions, title="parts found")
    heatmap(axes[0, 1], _where_found(klass, found), bits, resolutions,
            title=f"classification accuracy (kind and material; blank: under {_FEW:.0%} found)")
    heatmap(axes[1, 0], _where_found(pos, found), bits, resolutions,
            title=f"position error, mean (mm; blank: under {_FEW:.0%} of the parts found)",
            colours=dataclasses.replace(ERRORS, vmax=2.0))  # (one scale for every run: 0-2 mm)
    for ax in (axes[0, 0], axes[0, 1], axes[1, 0]):
        ax.set_xlabel("bits per channel")
    ax = axes[1, 1]
    full = max(bits) if bits else 8
    lat = [mean([r for r in rows if _res(r) == res and r.get("sensor.bits") == full], "detect_ms",
                statistics.median) for res in resolutions]
    ren = [mean([r for r in rows if _res(r) == res and r.get("sensor.bits") == full], "scene_s")
           for res in resolutions]
    xs = [_pixels(res) / 1e6 for res in resolutions]
    ax.plot(xs, [v if v is not None else float("nan") for v in lat], marker="o", label="detector")
    ax.set_xlabel("megapixels")
    ax.set_ylabel(f"ms per frame ({full} bits), median")
    ax.set_title("detector latency (one thread, right after the render; this machine)", fontsize=9)
    ax.grid(alpha=0.3)
    for x, y, res in zip(xs, lat, resolutions, strict=True):  # each label at its point
        if y is not None:
            ax.annotate(res, (x, y), textcoords="offset points", xytext=(6, -10), fontsize=7)
    heads = []
    if full in bits:
        j = bits.index(full)
        col = [(res, pos[i][j]) for i, res in enumerate(resolutions) if pos[i][j] is not None]
        if col:
            heads.append(f"position error at {full} bits: "
                         + ", ".join(f"{res} {v:.2f} mm" for res, v in col))
    for i, res in enumerate(resolutions):
        good = [(found[i][j] or 0) >= _GOOD and (klass[i][j] or 0) >= _GOOD for j in range(len(bits))]
        k = len(bits)
        while k > 0 and good[k - 1]:
            k -= 1
        heads.append(f"{res}: >= 90 % of the parts found and named right at every depth from "
                     f"{bits[k]} bits" if k < len(bits) else
                     f"{res}: fewer than 90 % of the parts found or named right even at {bits[-1]} bits")
    if lat and lat[0] is not None and lat[-1] is not None:
        heads.append(f"latency at {full} bits: {lat[0]:.1f} ms at {resolutions[0]} to {lat[-1]:.1f} ms at "
                     f"{resolutions[-1]} (render and scene {number(ren[0], '.2f')} to "
                     f"{number(ren[-1], '.2f')} s)")
    body = [[res] + [f"{number(found[i][j], '.0%')} / {number(klass[i][j], '.0%')} / "
                     f"{number(pos[i][j], '.2f')}" for j in range(len(bits))]
            for i, res in enumerate(resolutions)]
    table = markdown(["resolution"] + [f"{b} bits: found / class / mm" for b in bits], body)
    plot = Plot(PLOTS[0], "resolution and bit depth against parts found, classification, position "
                "error and latency", png(fig))
    return Report(tuple(heads), (plot,), (table,))
