"""``cell sweep`` and ``cell bench sweep`` on the command line: bad input is one error line
and exit status 2, never a traceback; the bench's JSON is strict."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.sweep.helpers import ROOT, write_tiny


def _cell(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, "-m", "cell.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=300)


def _one_error(r: subprocess.CompletedProcess, *words: str) -> str:
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr and r.stdout == ""
    errors = [ln for ln in r.stderr.splitlines() if "error:" in ln]
    assert len(errors) == 1, r.stderr
    for w in words:
        assert w in errors[0], (w, errors[0])
    return errors[0]


def test_bad_options_are_one_error_line(tmp_path):
    sweep = write_tiny(tmp_path)
    _one_error(_cell("sweep"), "--out")
    _one_error(_cell("sweep", str(sweep), "--out", str(tmp_path / "o"), "--workers", "0"), "--workers",
               "1 to 1024")
    _one_error(_cell("sweep", str(sweep), "--out", str(tmp_path / "o"), "--backend", "spark"), "--backend")
    _one_error(_cell("sweep", str(sweep), "--out", str(tmp_path / "o"), "--address", "x:1"),
               "--address", "only with --backend ray")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(("text", "words"), [
    ('[grid]\n"vision.threshold" = [100, 999]\n', ("vision.threshold", "out of range", "case 1")),
    ('[grid]\nlighting = ["front", "disco\\u001b[2J"]\n', ("lighting", "disco\\x1b[2J")),
    ('[sweep]\njob = "fly"\n', ("unknown job 'fly'",)),
])
def test_a_bad_sweep_file_is_one_error_naming_the_key_and_the_file(tmp_path, text, words):
    sweep = write_tiny(tmp_path, text, "bad.toml")
    line = _one_error(_cell("sweep", str(sweep), "--out", str(tmp_path / "o")), "bad.toml", *words)
    assert "\x1b" not in line
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_missing_files_and_used_folders_are_one_error(tmp_path):
    _one_error(_cell("sweep", str(tmp_path / "none.toml"), "--out", str(tmp_path / "o")),
               "no such sweep file")
    _one_error(_cell("sweep", str(tmp_path), "--out", str(tmp_path / "o")), "is a directory")
    sweep = write_tiny(tmp_path)
    used = tmp_path / "used"
    used.mkdir()
    (used / "results.csv").write_text("run_id\n")
    _one_error(_cell("sweep", str(sweep), "--out", str(used)), "pass --resume")
    (used / ".results.csv.abc.tmp").write_text("half")
    _one_error(_cell("sweep", str(sweep), "--out", str(used), "--resume"), "not this sweep's")
    assert sorted(p.name for p in used.iterdir()) == [".results.csv.abc.tmp", "results.csv"]
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    _one_error(_cell("sweep", str(sweep), "--out", str(loop)), "a symbolic link to nothing")
    (used / "notes.txt").write_text("mine")
    _one_error(_cell("sweep", str(sweep), "--out", str(used), "--resume"), "not sweep outputs")


@pytest.mark.parametrize("name", ["metrics.png", "summary.md"])
def test_an_output_taken_by_a_folder_is_refused_before_any_run(tmp_path, name):
    sweep, out = write_tiny(tmp_path), tmp_path / "out"
    (out / name).mkdir(parents=True)
    _one_error(_cell("sweep", str(sweep), "--out", str(out)), f"'{name}' is a folder, not a file")
    assert [p.name for p in out.iterdir()] == [name]  # no results.csv: nothing ran


def test_resume_refuses_a_binary_results_file_and_leaves_it(tmp_path):
    sweep, out = write_tiny(tmp_path), tmp_path / "out"
    out.mkdir()
    binary = b"\x7fELF\x02\x01\x01\x00" + bytes(range(11, 256)) * 12  # no newline: one "half row"
    (out / "results.csv").write_bytes(binary)
    _one_error(_cell("sweep", str(sweep), "--out", str(out), "--resume"), "results.csv",
               "not a whole header")
    assert [p.name for p in out.iterdir()] == ["results.csv"]
    assert (out / "results.csv").read_bytes() == binary


def test_bench_sweep_reports_strict_json():
    from cell.benchmarks import sweep

    report = sweep.run(seeds=1, repeats=1, ray=False)

    def reject(name: str):
        raise AssertionError(f"{name} in the JSON")

    out = json.loads(json.dumps(report, allow_nan=False), parse_constant=reject)
    assert out["grid"]["runs"] == 16 and out["same_rows"] is True
    assert set(out["setups"]) == {"local_1", "local_2"}
    for setup in out["setups"].values():
        assert setup["runs_per_min"] > 0 and setup["startup_s"] > 0
    assert out["ratios"]["local_2_over_local_1"] > 0 and out["ratios"]["ray_over_local_2"] is None
    _one_error(_cell("bench", "sweep", "--seeds", "0"), "--seeds")


def test_a_missing_ray_is_refused_before_the_output_folder_is_made(tmp_path):
    fake = tmp_path / "site" / "ray"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('no ray here')\n")
    sweep = write_tiny(tmp_path)
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
           "PYTHONPATH": os.pathsep.join([str(fake.parent), str(ROOT)])}
    r = subprocess.run([sys.executable, "-m", "cell.cli", "sweep", str(sweep), "--out",
                        str(tmp_path / "o"), "--backend", "ray"], capture_output=True, text=True,
                       cwd=ROOT, env=env, timeout=300)
    _one_error(r, "--backend ray needs Ray")
    assert not (tmp_path / "o").exists()


def test_sweep_options_made_in_code_are_checked_before_anything_is_written():
    # (workers=-1 raised a raw ValueError after creating the output folder; 0 meant all CPUs)
    import pytest

    from cell.sweep.errors import SweepError
    from cell.sweep.runner import SweepOptions

    for bad in ({"workers": 0}, {"workers": -1}, {"workers": 2.5}, {"backend": "dask"},
                {"chunk_runs": 0}):
        with pytest.raises(SweepError, match="SweepOptions: "):
            SweepOptions(**bad)


_DARK_SHY = '''
import numpy as np
from cell.vision.detector import PartDetector


class DarkShy:
    """Fails on a dark frame, as a user's detector might."""

    def __init__(self, settings):
        self.inner = PartDetector(settings)

    def detect(self, image, camera):
        if float(np.mean(image)) < 60:
            raise RuntimeError("too dark for me")
        return self.inner.detect(image, camera)
'''


def test_failed_runs_are_reported_by_light_and_counted_on_resume(tmp_path):
    """A light whose every run failed is a row of the lighting report and a finding (it
    vanished, and the report ranked front against itself: 'the same share under every
    light'); the failed runs name their light; --resume says how many resumed runs had
    failed (it said 0 failed)."""
    (tmp_path / "dark_shy.py").write_text(_DARK_SHY)
    sweep = write_tiny(tmp_path, "[sweep]\nname = \"shy\"\ntitle = \"shy\"\njob = \"detect\"\n"
                       "seeds = [1]\nreport = \"lighting\"\n[scenario]\n\"parts.count\" = 2\n"
                       "\"vision.detector\" = \"dark_shy:DarkShy\"\n[grid]\n"
                       "lighting = [\"front\", \"dim\"]\n")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    run = [sys.executable, "-m", "cell.cli", "sweep", str(sweep), "--out", str(tmp_path / "o"),
           "--workers", "1"]
    first = subprocess.run(run, capture_output=True, text=True, cwd=ROOT, env=env, timeout=300)
    assert first.returncode == 0 and "1 failed" in first.stdout, first.stderr
    summary = (tmp_path / "o" / "summary.md").read_text()
    assert "- dim: every run failed" in summary and "every light" not in summary
    assert "| dim |" in summary and "lighting = 'dim'): " in summary
    again = subprocess.run([*run, "--resume"], capture_output=True, text=True, cwd=ROOT, env=env,
                           timeout=300)
    assert "1 of the resumed had failed" in again.stdout, again.stdout
