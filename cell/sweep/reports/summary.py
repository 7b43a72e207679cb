"""``summary.md``: the study's question, its headline findings, plots and tables.

Written from ``results.csv`` alone (any run order, any number of sessions), through a
temporary file and a rename, after the plots it links to.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from cell.sweep.output import RESULTS, write_atomic
from cell.sweep.results import read_rows
from cell.text import escape

__all__ = ["summary_text", "write_summary"]


def _setup(plan, rows: list[dict]) -> list[str]:
    spec = plan.spec
    jobs = Counter(r.job for r in plan.runs)
    seeds = sorted({r.scenario.seed for r in plan.runs})
    seed_text = ", ".join(map(str, seeds[:8])) + (f", ... ({len(seeds)} seeds)" if len(seeds) > 8 else "")
    failed = sum(1 for r in rows if r.get("error"))
    lines = [
        f"- sweep file: `{escape(spec.source)}`; base scenario: "
        f"`{escape(str(spec.base)) if spec.base else '(defaults)'}`",
        f"- runs: {len(rows)} of {len(plan.runs)} in `{RESULTS}`"
        + (f" ({failed} failed: see below)" if failed else "")
        + "; jobs: " + ", ".join(f"{j} ({n})" for j, n in jobs.items()),
        f"- seeds: {seed_text}",
    ]
    if spec.scenario:
        lines.append("- fixed: " + ", ".join(f"`{escape(k)} = {escape(repr(v))}`" for k, v in spec.scenario))
    for i, case in enumerate(spec.cases, 1):
        axes = "; ".join(f"{', '.join(a.keys)}: {len(a.values)} values" for a in case.axes) or "one point"
        lines.append(f"- case {i}: job `{case.job}`, {axes}, {len(case.seeds)} seed(s)")
    return lines


def summary_text(plan, rows: list[dict], report) -> str:
    """The Markdown of ``summary.md``."""
    spec = plan.spec
    out = [f"# {escape(spec.title)}", ""]
    if spec.question:
        out += [f"*{escape(spec.question)}*", ""]
    out += ["## Findings", ""] + [f"- {h}" for h in report.headlines] + [""]
    out += ["## Set-up", ""] + _setup(plan, rows) + [""]
    if report.plots:
        out += ["## Plots", ""]
        for p in report.plots:
            out += [f"![{p.caption}]({p.file})", "", f"*{p.caption}*", ""]
    if report.tables:
        out += ["## Figures (mean over seeds; a rate is each run's own, so a run counts once "
                "whatever its number of parts)", ""]
        for t in report.tables:
            out += [t, ""]
    errors = [r for r in rows if r.get("error")]
    if errors:
        out += ["## Runs that failed", ""]
        varied = dict.fromkeys(k for case in spec.cases for axis in case.axes for k in axis.keys)
        for r in errors[:10]:
            where = "".join(f", {escape(k)} = {escape(repr(r[k]))}" for k in varied
                            if r.get(k) is not None)
            out.append(f"- `{r['run_id']}` (seed {r.get('seed')}{where}): {escape(str(r['error']))}")
        if len(errors) > 10:
            out.append(f"- ... and {len(errors) - 10} more (the `error` column of `{RESULTS}`)")
        out.append("")
    return "\n".join(out)


def write_summary(plan, out: Path) -> tuple[str, ...]:
    """Build ``plan``'s report from ``out``/results.csv and write its plots and summary.md."""
    from cell.sweep.reports import SUMMARY, report_module

    _, rows = read_rows(out / RESULTS)
    known = {r.run_id for r in plan.runs}
    rows = [r for r in rows if r.get("run_id") in known]
    module = report_module(plan.spec.report)
    report = module.build(rows, plan)
    files = []
    for p in report.plots:
        if p.file not in module.PLOTS:  # (the output folder was checked for PLOTS alone)
            raise ValueError(f"report {plan.spec.report!r} made {p.file!r}, not in its PLOTS")
        write_atomic(out / p.file, p.png)
        files.append(p.file)
    write_atomic(out / SUMMARY, summary_text(plan, rows, report).encode("utf-8"))
    return (*files, SUMMARY)
