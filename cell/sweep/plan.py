"""A sweep resolved into runs: every grid point and seed as a validated scenario and job
settings, with a run id, and the CSV's columns.

Each point's scenario is the base scenario with the ``[scenario]`` overrides and the
point's keys applied, validated by :func:`cell.config.build` exactly as a scenario file
(an unknown key, a wrong type or a value out of range names the key, the sweep file and
the case); the job's parameters likewise (``[job]`` applies to every case whose job has
that parameter). A run's id is a hash of its job, its parameters (every parameter column's
value: the grid's keys, the fixed ``[scenario]`` keys and the job's settings), its seed
and the base scenario file's parsed TOML, so a resumed sweep recognises its finished runs
whatever their order, and an edited base scenario or fixed setting makes a different
sweep (the scenario's other fields, at their defaults, are left out: a newer ``cell``
that adds a setting keeps the ids). Two points that resolve to the same run are one run.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import tomllib
from dataclasses import dataclass
from typing import Any

from cell.config import build, to_dict
from cell.scenario import Scenario, load_scenario
from cell.sweep.errors import SweepError
from cell.sweep.grid import product, size
from cell.sweep.jobs import job_module
from cell.sweep.spec import SweepSpec
from cell.text import escape, show

__all__ = ["FIXED_COLUMNS", "MAX_RUNS", "Columns", "Plan", "Run", "param_value", "plan_sweep", "run_id"]

MAX_RUNS = 1_000_000
FIXED_COLUMNS = ("run_id", "job", "seed")


@dataclass(frozen=True)
class Run:
    """One run: ``run_id`` (16 hex digits), ``job`` (its name), ``scenario`` (validated,
    with the run's seed) and ``settings`` (the job's ``Settings``)."""

    run_id: str
    job: str
    scenario: Scenario
    settings: Any


@dataclass(frozen=True)
class Columns:
    """The CSV's columns: ``params`` (every key the sweep file names, and every job
    parameter as ``job.KEY``), ``metrics`` and ``timings`` (wall times), then ``error``."""

    params: tuple[str, ...]
    metrics: tuple[str, ...]
    timings: tuple[str, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return (*FIXED_COLUMNS, *self.params, *self.metrics, *self.timings, "error")

    @property
    def numbers(self) -> tuple[str, ...]:
        """The columns that hold a finite number or nothing: the seed and the figures."""
        return ("seed", *self.metrics, *self.timings)


@dataclass(frozen=True)
class Plan:
    """A resolved sweep: the ``spec``, its ``runs`` (unique, in grid order) and ``columns``."""

    spec: SweepSpec
    runs: tuple[Run, ...]
    columns: Columns


def run_id(job: str, params: dict[str, Any], seed: int, base: str) -> str:
    """The id of a run: 16 hex digits of the SHA-256 of its job, parameter values, seed and
    the base scenario's fingerprint ``base``."""
    text = json.dumps({"job": job, "params": params, "seed": seed, "base": base},
                      sort_keys=True, separators=(",", ":"), default=list)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def param_value(run: Run, key: str) -> Any:
    """The value of parameter column ``key`` in ``run`` (None: the run's job has no such
    parameter)."""
    if key.startswith("job."):
        return getattr(run.settings, key[4:], None)
    node: Any = run.scenario
    for part in key.split("."):
        node = getattr(node, part)
    return node


def _set(data: dict, key: str, value: Any, where: str) -> dict:
    """A copy of the nested dict ``data`` with dotted ``key`` set to ``value`` (copied
    along the key's path only)."""
    parts = key.split(".")
    out = dict(data)
    node = out
    for i, part in enumerate(parts[:-1]):
        child = node.get(part, {})
        if not isinstance(child, dict):
            raise SweepError(f"{where}: key '{escape('.'.join(parts[:i + 1]))}' is not a "
                             f"section (in '{escape(key)}')")
        node[part] = node = dict(child)
    node[parts[-1]] = value
    return out


def _where(source: str, case: int, point: dict[str, Any]) -> str:
    text = ", ".join(f"{escape(k)}={show(v)}" for k, v in point.items())
    text = text if len(text) <= 160 else text[:157] + "..."
    return f"{escape(source)} (case {case}{': ' + text if text else ''})"


def _base(spec: SweepSpec) -> tuple[dict, str]:
    """The base scenario (fixed overrides applied) as a dict, and the fingerprint of the
    base scenario file (its TOML, as written)."""
    base = load_scenario(spec.base) if spec.base is not None else Scenario()
    raw = tomllib.loads(spec.base.read_text(encoding="utf-8-sig")) if spec.base is not None else {}
    fingerprint = hashlib.sha256(json.dumps(raw, sort_keys=True, default=str).encode()).hexdigest()
    data = to_dict(base)
    for key, value in spec.scenario:
        if key == "seed":
            raise SweepError(f"{escape(spec.source)}: [scenario] may not set 'seed'; list the seeds in "
                             "'sweep.seeds'")
        data = _set(data, key, value, escape(spec.source))
    build(Scenario, data, where=f"{spec.source} [scenario]")
    return data, fingerprint


def _job_data(spec: SweepSpec, settings_cls: type, point: dict[str, Any]) -> dict:
    fields = {f.name for f in dataclasses.fields(settings_cls)}
    data = {k[4:]: v for k, v in spec.job if k[4:] in fields}
    data.update({k[4:]: v for k, v in point.items() if k.startswith("job.")})
    return data


def plan_sweep(spec: SweepSpec) -> Plan:
    """Resolve ``spec`` into its runs; ``SweepError`` or ``ScenarioError`` naming the sweep
    file, the case and the key for any invalid key or value."""
    total = sum(size(c.axes) * len(c.seeds) for c in spec.cases)
    if total > MAX_RUNS:
        raise SweepError(f"{escape(spec.source)}: the grid holds {total} runs; at most {MAX_RUNS}")
    base, fingerprint = _base(spec)
    modules = {case.job: job_module(case.job) for case in spec.cases}
    known = {f"job.{f.name}" for m in modules.values() for f in dataclasses.fields(m.Settings)}
    for key, _ in spec.job:
        if key not in known:
            raise SweepError(f"{escape(spec.source)}: unknown key '{escape(key)}' in [job]; valid keys: "
                             f"{', '.join(sorted(known))}")
    fixed = {k: "[scenario]" for k, _ in spec.scenario} | {k: "[job]" for k, _ in spec.job}
    for i, case in enumerate(spec.cases, 1):
        for key in (k for axis in case.axes for k in axis.keys if k in fixed):
            raise SweepError(f"{escape(spec.source)}: case {i}: key '{escape(key)}' is both fixed "
                             f"in {fixed[key]} and set in the grid or the case (which would win "
                             f"while summary.md says fixed); set it in one place: in each case, "
                             f"or in [grid]")
    columns = _columns(spec, modules)
    runs: dict[str, Run] = {}
    settings_cache: dict[str, Any] = {}
    for i, case in enumerate(spec.cases, 1):
        cls = modules[case.job].Settings
        for point in product(case.axes):
            where = _where(spec.source, i, point)
            data = base
            for key, value in point.items():
                if not key.startswith("job."):
                    data = _set(data, key, value, where)
            scenario = build(Scenario, data, where=where)
            job_data = _job_data(spec, cls, point)
            cache_key = json.dumps([case.job, job_data], sort_keys=True, default=str)
            if cache_key not in settings_cache:
                settings_cache[cache_key] = build(cls, job_data, where=where, prefix="job.")
            settings = settings_cache[cache_key]
            params = {k: param_value(Run("", case.job, scenario, settings), k) for k in columns.params}
            for seed in case.seeds:
                rid = run_id(case.job, params, seed, fingerprint)
                runs.setdefault(rid, Run(rid, case.job, dataclasses.replace(scenario, seed=seed), settings))
    return Plan(spec, tuple(runs.values()), columns)


def _columns(spec: SweepSpec, modules: dict) -> Columns:
    params: list[str] = []
    for case in spec.cases:
        params += [k for axis in case.axes for k in axis.keys]
    params += [k for k, _ in spec.scenario]
    for module in modules.values():
        params += [f"job.{f.name}" for f in dataclasses.fields(module.Settings)]
    metrics = [m for module in modules.values() for m in module.METRICS]
    timings = [t for module in modules.values() for t in module.TIMINGS]
    return Columns(tuple(dict.fromkeys(params)), tuple(dict.fromkeys(metrics)),
                   tuple(dict.fromkeys(timings)))
