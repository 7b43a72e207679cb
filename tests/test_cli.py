"""The command line: snapshot writes its files; bad input exits 2 with one line."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from cell.options import float_in, int_in

ROOT = Path(__file__).parent.parent


def _cell(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, "-m", "cell.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=300)


def test_snapshot_writes_the_documented_files(tmp_path):
    out = tmp_path / "snap"
    r = _cell("snapshot", "scenarios/sort.toml", "--set", "parts.count=3", "--out", str(out))
    assert r.returncode == 0, r.stderr
    rgb = cv2.imread(str(out / "rgb.png"))
    depth, seg = np.load(out / "depth.npy"), np.load(out / "seg.npy")
    cam = json.loads((out / "camera.json").read_text())
    truth = json.loads((out / "truth.json").read_text())
    assert rgb.shape == (480, 640, 3) and depth.dtype == np.float32 and seg.dtype == np.int32
    assert depth.shape == seg.shape == (480, 640)
    assert set(cam) == {"width", "height", "K", "dist", "T_world_camera"}
    ids = {p["id"] for p in truth["parts"]}
    assert set(np.unique(seg)) - {0} <= ids and len(set(np.unique(seg)) - {0}) >= 1
    for row in truth["parts"]:
        assert set(row) == {"id", "kind", "material", "colour", "defect", "position", "quat", "yaw"}
    assert "part at the pick zone" in r.stdout


def test_bad_scenario_exits_2_with_one_line_and_no_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[conveyor]\nspeed = -1.0\n")
    r = _cell("snapshot", str(bad), "--out", str(tmp_path / "x"))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "conveyor.speed" in lines[0] and str(bad) in lines[0]
    assert "Traceback" not in r.stderr

    r = _cell("snapshot", "scenarios/sort.toml", "--set", "lighting=disco", "--out", str(tmp_path))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "valid: front, back" in r.stderr


def test_unknown_command_lists_the_valid_ones():
    r = _cell("fly")
    assert r.returncode == 2 and "valid: run, snapshot" in r.stderr


def test_no_arguments_prints_the_usage_to_stderr_and_exits_2():
    r = _cell()
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.startswith("usage: cell COMMAND")


def test_help_prints_the_usage_to_stdout_and_exits_0():
    r = _cell("--help")
    assert r.returncode == 0 and r.stderr == "" and "--version" in r.stdout


def test_version_prints_the_package_version():
    from importlib.metadata import version

    r = _cell("--version")
    assert r.returncode == 0 and r.stderr == ""
    assert r.stdout == f"cell {version('cell')}\n"


def test_user_strings_in_errors_are_printed_escaped(tmp_path):
    r = _cell("fly\x1b]0;owned\x07")
    assert r.returncode == 2 and "\x1b" not in r.stderr and "\x07" not in r.stderr
    assert "fly\\x1b]0;owned\\x07" in r.stderr and len(r.stderr.splitlines()) == 1

    # A CellError's message (here a scenario path with a line break and an escape) stays one line.
    r = _cell("snapshot", "no\nsuch\x1b[2J.toml", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.splitlines() == ["cell snapshot: error: no\\nsuch\\x1b[2J.toml: no such scenario file"]
    assert list(tmp_path.iterdir()) == []


def test_time_out_of_range_is_a_usage_error_without_traceback(tmp_path):
    r = _cell("snapshot", "scenarios/sort.toml", "--time", "nan", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "Traceback" not in r.stderr and r.stdout == ""
    assert r.stderr.startswith("usage: cell snapshot")
    assert [line for line in r.stderr.splitlines() if "error" in line] == [
        "cell snapshot: error: argument --time: must be a finite number of seconds in [0, 3600], "
        "got 'nan'"
    ]
    assert list(tmp_path.iterdir()) == []


def test_a_sweep_stopped_by_sigterm_inside_another_command_says_terminated(monkeypatch, capsys):
    # (cell bench sweep said 'interrupted' and exited 130 on SIGTERM)
    import types

    import cell.cli as cli
    from cell.errors import Terminated
    from cell.sweep.runner import SweepInterrupted

    def main(argv):
        raise SweepInterrupted(1, 2, Path("results.csv"), Terminated())

    monkeypatch.setattr(cli.importlib, "import_module", lambda name: types.SimpleNamespace(main=main))
    assert cli.main(["bench", "sweep"]) == 143
    assert capsys.readouterr().err.strip() == "cell bench: terminated"


def test_a_signal_once_the_command_is_done_changes_nothing():
    """Ctrl-C or SIGTERM in the tens of milliseconds the interpreter takes to shut down,
    the work done: exit status the command's, no word (a traceback of MuJoCo's EGL
    clean-up, or 130 with no line, before)."""
    code = ("import atexit, os, signal; from cell.cli import run; "
            "atexit.register(lambda: (os.kill(os.getpid(), signal.SIGINT), "
            "os.kill(os.getpid(), signal.SIGTERM))); run()")
    r = subprocess.run([sys.executable, "-c", code, "--version"], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0 and r.stdout.startswith("cell ") and r.stderr == "", r


def test_option_ranges_include_both_ends():
    whole, number = int_in(1, 8), float_in(0.0, 100.0)
    assert (whole("1"), whole(" 8 "), number("0"), number("100")) == (1, 8, 0.0, 100.0)
    for parse, text in ((whole, "0"), (whole, "9"), (number, "-0.5"), (number, "100.5"),
                        (number, "nan"), (number, "inf")):
        with pytest.raises(argparse.ArgumentTypeError, match="must be"):
            parse(text)
