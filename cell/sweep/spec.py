"""Sweep files: a study, a base scenario and a grid, validated into a ``SweepSpec``.

A sweep file is TOML::

    [sweep]
    name = "threshold"               # the study (printable; names the report)
    title = "Thresholds under each light"
    question = "Which grey level separates the parts from the belt?"
    base = "../sort.toml"            # the base scenario, relative to this file (default: none)
    job = "detect"                   # what each run does (cell.sweep.jobs)
    seeds = {from = 1, to = 3}       # a list, a range or one seed (default [0])
    report = "threshold"             # the study's plots and headline (default: generic)

    [scenario]                       # fixed overrides of the base scenario (dotted keys)
    "parts.count" = 6

    [job]                            # the job's fixed parameters
    gap_mm = 4.0

    [grid]                           # axes shared by every case (their product)
    lighting = ["front", "back"]

    [[case]]                         # the cases: the grid is their union (default: one case)
    "vision.segmentation" = "fixed"
    "vision.threshold" = {from = 0, to = 255, step = 15}

    [[case]]
    "vision.segmentation" = ["otsu", "belt"]

    [[case]]                         # a case may run another job, with other seeds
    job = "sort"
    seeds = [1]
    "vision.threshold" = [100, 150]

A case's axes are multiplied with the grid's (a case key also in the grid replaces that
axis for the case) and with the seeds. Keys are scenario keys (dotted, as ``--set``) or
``job.KEY`` for the job's parameters; ``seed`` is not a key (use ``seeds``). Values are
lists, ranges or single values (:mod:`cell.sweep.grid`). The file is read like a
scenario: missing, a folder, over 1 MiB, not UTF-8 or not TOML is one ``SweepError``
naming it; every key and value is checked when the runs are planned
(:mod:`cell.sweep.plan`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cell.files import input_path, read_toml_file
from cell.sweep.errors import SweepError
from cell.sweep.grid import Axis, flatten, parse_axes
from cell.sweep.jobs import JOBS
from cell.text import escape, show

__all__ = ["MAX_SEED", "Case", "SweepSpec", "load_sweep", "sweep_from_dict"]

MAX_SEED = 2**63 - 1
_SECTIONS = ("sweep", "scenario", "job", "grid", "case")
_SWEEP_KEYS = ("name", "title", "question", "base", "job", "seeds", "report")
_CASE_RESERVED = ("job", "seeds")


@dataclass(frozen=True)
class Case:
    """One case of a sweep: its ``job``, its ``seeds`` and its ``axes`` (the grid's axes
    merged with the case's own)."""

    job: str
    seeds: tuple[int, ...]
    axes: tuple[Axis, ...]


@dataclass(frozen=True)
class SweepSpec:
    """A sweep file, read and parsed (not yet resolved into runs).

    ``source`` names the file in messages; ``name``, ``title``, ``question`` describe the
    study; ``base`` is the base scenario's path (None: the default scenario); ``report``
    the study report that plots it; ``scenario`` the fixed scenario overrides and
    ``job`` the fixed job parameters (dotted key, value pairs); ``cases`` the grid.
    """

    source: str
    name: str
    title: str
    question: str
    base: Path | None
    report: str
    scenario: tuple[tuple[str, Any], ...]
    job: tuple[tuple[str, Any], ...]
    cases: tuple[Case, ...]


def _text(table: dict, key: str, default: str, where: str) -> str:
    value = table.get(key, default)
    if not isinstance(value, str) or not value.isprintable() or len(value) > 500:
        raise SweepError(f"{where}: key 'sweep.{key}' must be printable text of at most 500 "
                         f"characters, got {show(value)}")
    return value


def _seeds(value: object, where: str) -> tuple[int, ...]:
    from cell.sweep.grid import expand_range

    if isinstance(value, dict):
        values = expand_range(value, "seeds", where)
    elif isinstance(value, list):
        values = []
        for v in value:
            values += expand_range(v, "seeds", where) if isinstance(v, dict) else [v]
    else:
        values = [value]
    if not values:
        raise SweepError(f"{where}: key 'seeds' has no values")
    for v in values:
        if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= MAX_SEED:
            raise SweepError(f"{where}: key 'seeds': each seed must be an integer from 0 to "
                             f"2**63-1, got {show(v)}")
    if len(set(values)) != len(values):
        raise SweepError(f"{where}: key 'seeds' lists a seed twice")
    return tuple(values)


def _table(data: dict, key: str, where: str) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise SweepError(f"{where}: '{key}' must be a table ([{key}]), got {show(value)}")
    return value


def _pairs(table: dict, where: str, prefix: str = "") -> tuple[tuple[str, Any], ...]:
    out = []
    for key, value in flatten(table, where, prefix).items():
        if isinstance(value, dict):
            raise SweepError(f"{where}: key '{escape(key)}': a fixed value, not a range")
        out.append((key, value))
    return tuple(out)


def _check_keys(axes: list[Axis], where: str) -> None:
    for axis in axes:
        for key in axis.keys:
            if key == "seed":
                raise SweepError(f"{where}: 'seed' is not a grid key; list the seeds in 'seeds'")


def sweep_from_dict(data: dict, *, source: str, folder: Path) -> SweepSpec:
    """Parse a sweep file's TOML dict; ``source`` names it in messages, ``folder`` is where
    a relative ``base`` path starts."""
    where = escape(source)
    unknown = sorted(k for k in data if k not in _SECTIONS)
    if unknown:
        raise SweepError(f"{where}: unknown section '{escape(unknown[0])}'; valid: "
                         f"{', '.join(_SECTIONS)}")
    sweep = _table(data, "sweep", where)
    bad = sorted(k for k in sweep if k not in _SWEEP_KEYS)
    if bad:
        raise SweepError(f"{where}: unknown key 'sweep.{escape(bad[0])}'; valid keys: "
                         f"{', '.join('sweep.' + k for k in _SWEEP_KEYS)}")
    name = _text(sweep, "name", Path(source).stem or "sweep", where)
    base_text = sweep.get("base")
    base = None
    if base_text is not None:
        if not isinstance(base_text, str) or not base_text:
            raise SweepError(f"{where}: key 'sweep.base' must be a scenario file's path, got "
                             f"{show(base_text)}")
        base = Path(os.path.normpath(folder / base_text))
    job = _text(sweep, "job", "detect", where)
    report = _text(sweep, "report", "generic", where)
    from cell.sweep.reports import REPORTS

    if report not in REPORTS:
        raise SweepError(f"{where}: key 'sweep.report' = {show(report)} is no report; valid: "
                         f"{', '.join(REPORTS)}")
    seeds = _seeds(sweep.get("seeds", [0]), where)
    grid = parse_axes(_table(data, "grid", where), where)
    _check_keys(grid, where)
    raw_cases = data.get("case", [{}])
    if not isinstance(raw_cases, list) or not raw_cases or not all(isinstance(c, dict) for c in raw_cases):
        raise SweepError(f"{where}: 'case' must be one or more tables ([[case]])")
    cases = []
    for i, raw in enumerate(raw_cases, 1):
        here = f"{where} (case {i})"
        case_job = raw.get("job", job)
        if not isinstance(case_job, str):
            raise SweepError(f"{here}: key 'job' must be a job's name, got {show(case_job)}; "
                             "quote job parameters beside it (\"job.KEY\" = ...)")
        if case_job not in JOBS:
            raise SweepError(f"{here}: unknown job {show(case_job)}; valid: {', '.join(JOBS)}")
        own = parse_axes(raw, here, reserved=_CASE_RESERVED)
        _check_keys(own, here)
        replaced = {k for a in own for k in a.keys}
        merged = [a for a in grid if not replaced & set(a.keys)] + own
        case_seeds = _seeds(raw["seeds"], here) if "seeds" in raw else seeds
        cases.append(Case(case_job, case_seeds, tuple(merged)))
    return SweepSpec(
        source=source, name=name, title=_text(sweep, "title", name, where),
        question=_text(sweep, "question", "", where), base=base,
        report=report,
        scenario=_pairs(_table(data, "scenario", where), where),
        job=_pairs(_table(data, "job", where), where, "job."), cases=tuple(cases))


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and parse the sweep file ``path`` (see the module docstring)."""
    path, shown = input_path(path, kind="sweep file", error=SweepError)
    data = read_toml_file(path, shown, kind="sweep file", error=SweepError)
    return sweep_from_dict(data, source=str(path), folder=path.parent)
