"""The compression study's report: bytes per frame against the detector's accuracy.

Plot ``compression.png``: left, the compression ratio of each codec (JPEG per quality, PNG,
RLE of the image; RLE and PNG of the binary part mask); right, the detector on the
decoded JPEG images against the quality (parts found, classification accuracy, position
error), with the lossless codecs' figures as the reference (means over the seeds).
"""

from __future__ import annotations

from cell.sweep.reports.table import Plot, Report, done, figure, markdown, mean, number, png, values

__all__ = ["PLOTS", "build"]

PLOTS = ("compression.png",)  # the plots it writes (checked before the runs)


def _lossless(rows: list[dict]) -> list[dict]:
    return [r for r in rows if r.get("job.codec") in ("png", "rle")]


def _chromas(jpeg: list[dict]) -> list:
    return values(jpeg, "job.chroma") or [None]


def _at(jpeg: list[dict], q, chroma) -> list[dict]:
    return [r for r in jpeg if r.get("job.quality") == q and r.get("job.chroma") == chroma]


def _figure(rows: list[dict], qualities: list, jpeg: list[dict]) -> bytes:
    fig, axes = figure(1, 2, size=(11.5, 5.0))
    ax = axes[0, 0]
    names, ratios = [], []
    for chroma in _chromas(jpeg):
        names += [f"jpeg {q} ({chroma})" for q in qualities]
        ratios += [mean(_at(jpeg, q, chroma), "ratio") for q in qualities]
    n_jpeg = len(names)
    for codec in ("png", "rle"):
        members = [r for r in rows if r.get("job.codec") == codec]
        if members:
            names.append(f"{codec} (image)")
            ratios.append(mean(members, "ratio"))
    rle = [r for r in rows if r.get("job.codec") == "rle"]
    if rle and mean(rle, "mask_ratio") is not None:
        raw = mean(rle, "mask_raw_bytes")
        names += ["rle (mask)", "png (mask)"]
        ratios += [mean(rle, "mask_ratio"), raw / mean(rle, "mask_png_bytes") if raw else None]
    ax.barh(range(len(names)), [r or 0 for r in ratios], color=["tab:blue"] * n_jpeg
            + ["tab:green"] * (len(names) - n_jpeg))
    ax.set_yticks(range(len(names)), names, fontsize=6)
    ax.set_xscale("log")
    ax.axvline(1.0, color="black", lw=0.8)
    ax.set_xlabel("compression ratio (raw / coded; log; masks against 1 bit per pixel)")
    ax.invert_yaxis()
    ax.grid(axis="x", alpha=0.3)
    ax = axes[0, 1]
    lossless = _lossless(rows)
    twin = ax.twinx()
    for chroma, ls in zip(_chromas(jpeg), ("-", "--", ":"), strict=False):
        for metric, name, colour in (("recall", "parts found", "tab:blue"),
                                     ("classification_accuracy", "classification", "tab:orange")):
            ys = [mean(_at(jpeg, q, chroma), metric) for q in qualities]
            ax.plot(qualities, [y if y is not None else float("nan") for y in ys], marker="o", ls=ls,
                    color=colour, label=f"{name}, jpeg {chroma}")
        ys = [mean(_at(jpeg, q, chroma), "position_error_mm_mean") for q in qualities]
        twin.plot(qualities, [y if y is not None else float("nan") for y in ys], marker="s", ls=ls,
                  color="tab:red", label=f"position, jpeg {chroma}")
    for metric, colour in (("recall", "tab:blue"), ("classification_accuracy", "tab:orange")):
        ref = mean(lossless, metric)
        if ref is not None:
            ax.axhline(ref, color=colour, ls=":", lw=0.8)
    ax.set_ylim(0, 1.05)
    ax.set_xlabel("JPEG quality (dotted: lossless)")
    ax.set_ylabel("share")
    twin.set_ylabel("position error, mean (mm)", color="tab:red")
    handles, labels = ax.get_legend_handles_labels()
    more, more_labels = twin.get_legend_handles_labels()
    ax.legend(handles + more, labels + more_labels, fontsize=7, ncol=3, loc="upper center",
              bbox_to_anchor=(0.5, -0.14), frameon=False)
    ax.grid(alpha=0.3)
    fig.suptitle("Compression ratio per codec, and the detector on decoded JPEG frames", fontsize=9)
    return png(fig)


def build(rows: list[dict], plan) -> Report:
    rows = [r for r in done(rows) if r.get("job") == "compress"]
    if not rows:
        return Report(("No run finished.",), (), ())
    jpeg = [r for r in rows if r.get("job.codec") == "jpeg"]
    qualities = values(jpeg, "job.quality")
    lossless = _lossless(rows)
    heads, body = [], []
    base_class, base_pos = mean(lossless, "classification_accuracy"), mean(lossless, "position_error_mm_mean")
    for codec in ("png", "rle"):
        members = [r for r in rows if r.get("job.codec") == codec]
        if members:
            heads.append(f"{codec} (lossless) of the frame: {mean(members, 'bytes') / 1e3:.0f} kB per frame, "
                         f"ratio {mean(members, 'ratio'):.2f}")
            body.append([codec, "-", f"{mean(members, 'bytes') / 1e3:.1f}",
                         number(mean(members, "ratio"), ".2f"),
                         "-", number(mean(members, "recall"), ".0%"),
                         number(mean(members, "classification_accuracy"), ".0%"),
                         number(mean(members, "position_error_mm_mean"), ".2f")])
    rle = [r for r in rows if r.get("job.codec") == "rle"]
    if rle and mean(rle, "mask_rle_bytes") is not None:
        heads.append(f"the binary part mask: RLE {mean(rle, 'mask_rle_bytes'):.0f} bytes (ratio "
                     f"{mean(rle, 'mask_ratio'):.0f} against 1 bit per pixel, "
                     f"{mean(rle, 'mask_raw_bytes'):.0f} bytes), PNG {mean(rle, 'mask_png_bytes'):.0f} bytes")
    for chroma in _chromas(jpeg):
        keeps = []
        for q in qualities:
            m = _at(jpeg, q, chroma)
            c, p = mean(m, "classification_accuracy"), mean(m, "position_error_mm_mean")
            body.append([f"jpeg {chroma}", str(q), f"{mean(m, 'bytes') / 1e3:.1f}",
                         number(mean(m, "ratio"), ".1f"), number(mean(m, "psnr_db"), ".1f"),
                         number(mean(m, "recall"), ".0%"), number(c, ".0%"), number(p, ".2f")])
            if (c is not None and base_class is not None and c >= base_class - 0.02 and p is not None
                    and base_pos is not None and p <= base_pos + 0.05 and (mean(m, "recall") or 0)
                    >= (mean(lossless, "recall") or 0) - 0.02):
                keeps.append(q)
        if not lossless:  # nothing to compare with: the table only
            continue
        # the lowest quality from which every higher one keeps the figures
        k = len(qualities)
        while k > 0 and qualities[k - 1] in keeps:
            k -= 1
        if k < len(qualities):
            q = qualities[k]
            m = _at(jpeg, q, chroma)
            heads.append(f"JPEG {chroma} keeps the detector's figures (within 2 points and 0.05 mm of "
                         f"lossless) from quality {q} up: {mean(m, 'bytes') / 1e3:.1f} kB per frame, "
                         f"ratio {mean(m, 'ratio'):.0f}")
        elif qualities:
            m = _at(jpeg, qualities[-1], chroma)
            heads.append(f"JPEG {chroma} loses detector accuracy even at quality {qualities[-1]}: parts "
                         f"found {number(mean(m, 'recall'), '.0%')}, classification "
                         f"{number(mean(m, 'classification_accuracy'), '.0%')}, position "
                         f"{number(mean(m, 'position_error_mm_mean'), '.2f')} mm (lossless "
                         f"{number(base_pos, '.2f')} mm), at ratio {mean(m, 'ratio'):.0f}")
    if jpeg and not lossless:
        heads.append("no lossless run (png or rle) in this grid: the JPEG figures have no reference "
                     "to be judged against")
    table = markdown(["codec", "quality", "kB / frame", "ratio", "PSNR dB", "found", "classification",
                      "position mm"], body)
    plot = Plot(PLOTS[0], "compression ratio per codec, and the detector on decoded frames",
                _figure(rows, qualities, jpeg))
    return Report(tuple(heads), (plot,), (table,))
