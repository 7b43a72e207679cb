"""Helpers of the sweep tests: small sweep files, a shrunk study, an in-process backend and
results compared without their wall-time columns."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from cell.sweep.grid import Axis
from cell.sweep.plan import Plan
from cell.sweep.results import read_rows
from cell.sweep.spec import SweepSpec
from cell.sweep.worker import run_tasks

ROOT = Path(__file__).parent.parent.parent
STUDIES = ROOT / "scenarios" / "sweeps"

TINY = """
[sweep]
name = "tiny"
title = "a tiny sweep"
job = "detect"
seeds = [1, 2]

[scenario]
"parts.count" = 2

[grid]
lighting = ["front", "back"]

[[case]]
"vision.segmentation" = "fixed"
"vision.threshold" = [100, 150]

[[case]]
"vision.segmentation" = "belt"
"""
"""A detect sweep of 10 runs on 4 scenes (2 lights x 2 seeds), 2 parts each."""


def write_tiny(folder: Path, text: str = TINY, name: str = "tiny.toml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


class Inline:
    """A backend that runs each chunk in this process, one after another (no pool)."""

    workers = 1

    def start(self) -> None:
        pass

    def close(self) -> None:
        pass

    def run(self, chunks, on_outcomes) -> None:
        for chunk in chunks:
            on_outcomes(run_tasks(chunk))


def shrink(spec: SweepSpec, *, keep: int = 2, parts: int = 2) -> SweepSpec:
    """``spec`` with the first ``keep`` values of each axis (one for a sort case), one seed,
    and ``parts`` parts per scene: a tiny version of a study."""
    cases = []
    for case in spec.cases:
        n = 1 if case.job == "sort" else keep
        axes = tuple(Axis(a.keys, a.values[:n]) for a in case.axes)
        cases.append(dataclasses.replace(case, seeds=case.seeds[:1], axes=axes))
    fixed = tuple((k, v) for k, v in spec.scenario if k != "parts.count") + (("parts.count", parts),)
    return dataclasses.replace(spec, cases=tuple(cases), scenario=fixed)


def rows_without_timings(path: Path, plan: Plan) -> list[tuple]:
    """The rows of a results file, sorted, without the wall-time columns."""
    _, rows = read_rows(path)
    drop = set(plan.columns.timings)
    return sorted(tuple((k, v) for k, v in r.items() if k not in drop) for r in rows)
