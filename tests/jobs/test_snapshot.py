"""``cell snapshot`` hardening: bad ``--time``/``--seed``/``--out`` are one error line and exit 2;
an output set is written whole (staged beside the folder, swapped into place) or not at all."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from cell import cli
from cell.jobs import snapshot
from cell.jobs.snapshot import truth_rows
from cell.scenario import load_scenario
from cell.sim.world import World

ROOT = Path(__file__).parent.parent.parent
SCENARIO = str(ROOT / "scenarios" / "sort.toml")
# A small scene: one part and a 64x48 image keep each rendering run well under a second.
SMALL = [SCENARIO, "--set", "parts.count=1", "--set", "camera.width=64", "--set", "camera.height=48"]
DOCUMENTED = {"rgb.png", "depth.npy", "seg.npy", "camera.json", "truth.json"}


def run(capsys, *args: str) -> tuple[int, str, str]:
    """``cell snapshot ARGS`` in this process: (exit status, stdout, stderr)."""
    try:
        rc = cli.main(["snapshot", *args])
    except SystemExit as exc:  # argparse's usage errors
        rc = exc.code
    captured = capsys.readouterr()
    return rc, captured.out, captured.err


def assert_one_error_line(err: str, *needles: str) -> str:
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if "error:" in line]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert all(ch.isprintable() for ch in lines[0]), lines[0]
    return lines[0]


def tree(folder: Path) -> dict[str, bytes | None]:
    """Every entry under ``folder`` with its bytes (None for folders)."""
    return {str(p.relative_to(folder)): (None if p.is_dir() else p.read_bytes())
            for p in sorted(folder.rglob("*"))}


def old_run(folder: Path, *, xml: bool = False) -> None:
    """A folder as an earlier snapshot left it (contents marked as old)."""
    folder.mkdir()
    for name in DOCUMENTED | ({"cell.xml"} if xml else set()):
        (folder / name).write_bytes(b"old " + name.encode())


# --- item 4: --time ---------------------------------------------------------------------

@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "-5", "-0.001", "3600.5", "1e400"])
def test_time_must_be_finite_and_in_range(capsys, tmp_path, value):
    rc, out, err = run(capsys, *SMALL, f"--time={value}", "--out", str(tmp_path / "o"))
    assert rc == 2 and out == ""
    assert_one_error_line(err, "--time", "3600")
    assert err.startswith("usage: cell snapshot")
    assert list(tmp_path.iterdir()) == []


# --- item 5: --out ----------------------------------------------------------------------

def test_empty_out_is_an_error_and_writes_nothing_in_the_current_folder(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc, out, err = run(capsys, *SMALL, "--time", "0", "--out", "")
    assert rc == 2 and out == ""
    assert_one_error_line(err, "--out ''")
    assert list(tmp_path.iterdir()) == []


def test_out_that_is_the_current_folder_is_refused(capsys, tmp_path, monkeypatch):
    old_run(tmp_path / "snap")
    before = tree(tmp_path)
    monkeypatch.chdir(tmp_path / "snap")
    rc, _, err = run(capsys, *SMALL, "--time", "0", "--out", ".")
    assert rc == 2
    assert_one_error_line(err, "--out '.'", "current folder")
    assert tree(tmp_path) == before


@pytest.mark.parametrize("case", ["existing file", "under a file", "name too long", "escaped"])
def test_out_that_cannot_be_a_folder_is_one_error_line(capsys, tmp_path, case):
    (tmp_path / "f").write_text("keep")
    (tmp_path / "f\x1b[2J").write_text("keep")
    out = {"existing file": tmp_path / "f", "under a file": tmp_path / "f" / "sub" / "o",
           "name too long": tmp_path / ("x" * 300), "escaped": tmp_path / "f\x1b[2J"}[case]
    before = tree(tmp_path)
    rc, stdout, err = run(capsys, *SMALL, "--time", "0", "--out", str(out))
    assert rc == 2 and stdout == ""
    line = assert_one_error_line(err, "--out")
    if case == "escaped":
        assert "f\\x1b[2J" in line and "\x1b" not in err
    else:
        assert str(out) in line
    assert tree(tmp_path) == before


def test_out_holding_other_files_is_refused_and_left_alone(capsys, tmp_path):
    old_run(tmp_path / "snap")
    (tmp_path / "snap" / "notes.txt").write_text("mine")
    before = tree(tmp_path)
    rc, _, err = run(capsys, *SMALL, "--time", "0", "--out", str(tmp_path / "snap"))
    assert rc == 2
    assert_one_error_line(err, str(tmp_path / "snap"), "notes.txt")
    assert tree(tmp_path) == before


# --- item 6: outputs written whole --------------------------------------------------------

def test_a_failed_run_creates_nothing(capsys, tmp_path):
    out = tmp_path / "a" / "b" / "snap"  # missing parents are not left behind either
    rc, _, err = run(capsys, *SMALL, "--set", "conveyor.mode=continuous", "--out", str(out))
    assert rc == 2
    assert_one_error_line(err, "continuous")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_run_leaves_the_earlier_output_as_it_was(capsys, tmp_path):
    old_run(tmp_path / "snap", xml=True)
    before = tree(tmp_path)
    rc, _, _ = run(capsys, *SMALL, "--set", "conveyor.mode=continuous", "--out", str(tmp_path / "snap"))
    assert rc == 2 and tree(tmp_path) == before


def _fail_imencode(*_args, **_kw):
    return False, None


def _fail_on(name: str, real):
    def save(file, *args, **kw):
        if str(file).endswith(name):
            raise OSError(28, "No space left on device")
        return real(file, *args, **kw)
    return save


def _nan_rows(_world):
    return [{"id": 1, "position": [0.0, 0.0, math.nan]}]


@pytest.mark.parametrize("failure", ["imencode returns False", "disk full at seg.npy", "NaN in truth"])
def test_a_failed_write_is_an_error_and_changes_nothing(capsys, tmp_path, monkeypatch, failure):
    if failure == "imencode returns False":
        monkeypatch.setattr(cv2, "imencode", _fail_imencode)
        culprit = "rgb.png"
    elif failure == "disk full at seg.npy":
        monkeypatch.setattr(np, "save", _fail_on("seg.npy", np.save))
        culprit = "seg.npy"
    else:
        monkeypatch.setattr(snapshot, "truth_rows", _nan_rows)
        culprit = "truth.json"
    old_run(tmp_path / "snap")
    before = tree(tmp_path)
    rc, out, err = run(capsys, *SMALL, "--time", "0.05", "--out", str(tmp_path / "snap"))
    assert rc == 2 and out == ""
    assert_one_error_line(err, str(tmp_path / "snap" / culprit))
    assert tree(tmp_path) == before


def test_a_new_run_replaces_the_whole_set_and_leaves_no_stale_files(capsys, tmp_path):
    old_run(tmp_path / "snap", xml=True)
    rc, out, err = run(capsys, *SMALL, "--time", "0", "--out", str(tmp_path / "snap"))
    assert rc == 0, err
    assert [p.name for p in tmp_path.iterdir()] == ["snap"]  # no staging or set-aside folders
    assert {p.name for p in (tmp_path / "snap").iterdir()} == DOCUMENTED  # stale cell.xml gone
    assert cv2.imread(str(tmp_path / "snap" / "rgb.png")).shape == (48, 64, 3)
    assert json.loads((tmp_path / "snap" / "truth.json").read_text()) == {"parts": [], "caught": []}
    assert f"to {tmp_path / 'snap'}/" in out

    rc, out, err = run(capsys, *SMALL, "--time", "0", "--save-xml", "--out", str(tmp_path / "snap"))
    assert rc == 0, err
    assert {p.name for p in (tmp_path / "snap").iterdir()} == DOCUMENTED | {"cell.xml"}
    assert "cell.xml" in out and (tmp_path / "snap" / "cell.xml").read_text().startswith("<mujoco")


def test_missing_parents_are_created_on_success(capsys, tmp_path):
    out = tmp_path / "a" / "b" / "snap"
    rc, _, err = run(capsys, *SMALL, "--time", "0", "--out", str(out))
    assert rc == 0, err
    assert {p.name for p in out.iterdir()} == DOCUMENTED
    assert [p.name for p in (tmp_path / "a" / "b").iterdir()] == ["snap"]


# --- item 13: --seed ----------------------------------------------------------------------

@pytest.mark.parametrize("value", ["-5", str(2**63), "1.5"])
def test_a_bad_seed_names_the_seed_option(capsys, tmp_path, value):
    rc, _, err = run(capsys, *SMALL, "--seed", value, "--out", str(tmp_path / "o"))
    assert rc == 2
    line = assert_one_error_line(err, "--seed")
    assert "--set" not in line
    assert list(tmp_path.iterdir()) == []


_UTF8_NAMES = pytest.mark.skipif(
    sys.getfilesystemencoding().lower().replace("-", "") != "utf8",
    reason="a byte that is no character exists only under a UTF-8 file system encoding")


@_UTF8_NAMES
def test_an_undecodable_out_path_is_printed_escaped(capsys, tmp_path):
    bad = os.fsdecode(b"bad\xff")  # an undecodable file name, as argv gives it
    (tmp_path / bad).write_text("x")
    rc, _, err = run(capsys, *SMALL, "--time", "0", "--out", str(tmp_path / bad))
    assert rc == 2
    assert_one_error_line(err, "bad\\udcff")


@_UTF8_NAMES
def test_an_out_path_that_is_not_utf8_is_written(tmp_path):
    # (a subprocess: before, cv2.imwrite crashed the process on such a path)
    out = os.path.join(os.fsencode(tmp_path), b"snap\xe9")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    r = subprocess.run([sys.executable, "-m", "cell.cli", "snapshot", *[os.fsencode(a) for a in SMALL],
                        "--time", "0", "--out", out], capture_output=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert {os.fsdecode(n) for n in os.listdir(out)} == DOCUMENTED
    assert os.listdir(tmp_path) == [os.fsdecode(b"snap\xe9")]


def test_a_failed_swap_puts_the_earlier_output_back(capsys, tmp_path, monkeypatch):
    old_run(tmp_path / "snap")
    before = tree(tmp_path)
    real_rename = os.rename

    def rename(src, dst):
        if ".tmp-" in str(src):  # the staged set cannot take the folder's place
            raise OSError(16, "Device or resource busy")
        return real_rename(src, dst)

    monkeypatch.setattr(os, "rename", rename)
    rc, _, err = run(capsys, *SMALL, "--time", "0", "--out", str(tmp_path / "snap"))
    assert rc == 2
    assert_one_error_line(err, "cannot be replaced", "busy")
    assert tree(tmp_path) == before


def test_the_snapshot_is_the_world_after_time_s_in_its_true_colours(capsys, tmp_path):
    out = tmp_path / "snap"
    rc, _, err = run(capsys, *SMALL, "--time", "0.3", "--out", str(out))
    assert rc == 0, err
    world = World.build(load_scenario(SCENARIO, overrides=SMALL[2::2]))
    try:
        world.step(round(0.3 / world.model.opt.timestep))
        frame, truth = world.render("overhead"), truth_rows(world)
    finally:
        world.close()
    assert truth, "a part is on the belt after 0.3 s"
    saved = json.loads((out / "truth.json").read_text())["parts"]
    assert [p["position"] for p in saved] == [p["position"] for p in truth]
    rgb = cv2.cvtColor(cv2.imread(str(out / "rgb.png")), cv2.COLOR_BGR2RGB)  # as any reader loads it
    assert np.array_equal(rgb, frame.rgb)
