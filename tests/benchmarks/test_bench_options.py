"""``cell bench``: bad options are one error line and exit 2; no output ever holds NaN;
``cell bench --help`` lists every benchmark's options (issue 12, items 10 and 13)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cell.benchmarks import pick, vision
from cell.benchmarks.vision_score import Tally, summarise

ROOT = Path(__file__).parent.parent.parent


def _cell(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, "-m", "cell.cli", *args], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=300)


def _strict_json(text: str) -> dict:
    def reject(name: str):
        raise AssertionError(f"{name} in the JSON output")

    return json.loads(text, parse_constant=reject)


# Each would run (small: one kind, one pose, --quick) if the option were accepted.
@pytest.mark.parametrize(("args", "option"), [
    (["pick", "--kinds"], "--kinds"),                                  # ZeroDivisionError
    (["pick", "--kinds", "bolt", "--poses", "0"], "--poses"),          # ZeroDivisionError
    (["pick", "--kinds", "bolt", "--poses", "-3"], "--poses"),         # 'parts.count' named
    (["pick", "--kinds", "bolt", "--poses", "1", "--pose-noise-mm", "nan"], "--pose-noise-mm"),
    (["pick", "--kinds", "bolt", "--poses", "1", "--pose-noise-mm", "-1"], "--pose-noise-mm"),
    (["pick", "--kinds", "bolt", "--poses", "1", "--yaw-noise-deg", "inf"], "--yaw-noise-deg"),
    (["pick", "--kinds", "bolt", "--poses", "1", "--seed", "-5"], "--seed"),
    (["pick", "--kinds", "bolt", "--poses", "1", "--seed", "1" + "0" * 30], "--seed"),
    (["vision", "--scenes", "-2"], "--scenes"),                        # IndexError
    (["vision", "--scenes", "0", "--parts", "1", "--presets", "front"], "--scenes"),  # default
    (["vision", "--scenes", "2", "--seed-base", str(2**63 - 1), "--presets", "front"],
     "--seed-base"),
    (["vision", "--scenes", "1", "--parts", "1", "--presets", ","], "--presets"),
    (["calib", "--seeds", "0"], "--seeds"),
    (["calib", "--seed-base", "999"], "--seed-base"),                  # a seed the tests use
    (["calib", "--seeds", "2", "--seed-base", str(2**63 - 1)], "--seed-base"),
    (["calib", "--poses", "2"], "--poses"),
    (["calib", "--setups", ","], "--setups"),
    (["calib", "--setups", "default,fog"], "--setups"),
    (["calib", "--set", "calibration.poses=x"], "--set"),
    (["render", "--quick", "--repeats", "0"], "--repeats"),            # NaN table
    (["render", "--quick", "--repeats", "-1"], "--repeats"),
])
def test_a_bad_option_is_one_error_line_and_exit_2(args, option):
    r = _cell("bench", *args)
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    assert "Traceback" not in r.stderr and r.stdout == ""
    errors = [ln for ln in r.stderr.splitlines() if "error:" in ln]
    assert len(errors) == 1 and r.stderr.startswith("usage: cell bench "), r.stderr
    assert errors[0].startswith(f"cell bench {args[0]}: error: argument {option}:"), errors[0]
    assert "parts.count" not in r.stderr and "nan" not in r.stderr.lower().replace("'nan'", "")


ESC = "\x1b[31mX\n"  # a user's terminal escape and line break: each error line shows them escaped


@pytest.mark.parametrize("args", [
    *([name, f"--{ESC}"] for name in ("render", "vision", "pick", "calib", "sort", "sweep")),
    *([name, ESC] for name in ("render", "vision", "pick", "calib", "sort", "sweep")),  # extra argument
    ["vision", "--presets", ESC],
    ["vision", "--presets", f"front,{ESC}"],
    ["calib", "--setups", ESC],
    ["pick", "--kinds", ESC],
    ["sort", "--scenarios", ESC],
    ["calib", "--set", f"{ESC}=1"],
    [ESC],
], ids=lambda args: " ".join(args).encode("unicode_escape").decode())
def test_option_errors_print_the_users_text_escaped(args, capsys):
    from cell.cli import main as cell_main

    try:
        code = cell_main(["bench", *args])
    except SystemExit as exc:  # argparse's exit
        code = exc.code
    out, err = capsys.readouterr()
    assert code == 2 and out == "", (code, err)
    errors = [ln for ln in err.splitlines() if "error:" in ln]
    assert len(errors) == 1 and errors[0].startswith("cell bench"), err
    assert "\x1b" not in err and r"\x1b[31mX" in errors[0], errors[0]  # (lists drop the \n)


def test_list_options_name_their_valid_choices():
    r = _cell("bench", "pick", "--kinds")
    assert "washer, hex_nut, square_nut, bolt, l_bracket, disc" in r.stderr
    r = _cell("bench", "pick", "--kinds", "gear")
    assert r.returncode == 2 and "invalid choice: 'gear'" in r.stderr and "'washer'" in r.stderr
    r = _cell("bench", "vision", "--presets", ",")
    assert r.returncode == 2 and "front, back, raking" in r.stderr


def test_each_help_states_the_ranges():
    helps = {name: mod.parser().format_help() for name, mod in
             (("pick", pick), ("vision", vision))}
    for text in ("--poses N", "1 to 199", "0 to 100 mm", "0 to 180 deg", "washer, hex_nut"):
        assert text in " ".join(helps["pick"].split()), text
    for text in ("1 to 100000", "1 to 20", "1000 to 2**63-1", "front, back, raking"):
        assert text in " ".join(helps["vision"].split()), text
    from cell.benchmarks import calib, render

    assert "1 to 10000" in render.parser().format_help()
    text = " ".join(calib.parser().format_help().split())
    for part in ("1 to 1000", "1000 to 2**63-1", "3 to 200", "default, distortion, joint_noise", "KEY=VALUE"):
        assert part in text, part


def test_a_pick_with_no_finished_cycle_reports_null_and_dash(monkeypatch, capsys):
    from cell.errors import CellError
    from cell.robot.pick import PickPlace

    def fail(self, target):
        raise CellError("no cycle (test)")

    monkeypatch.setattr(PickPlace, "run", fail)
    assert pick.main(["--kinds", "bolt", "--poses", "1", "--json"]) == 0
    out = _strict_json(capsys.readouterr().out)
    row, overall = out["kinds"]["bolt"], out["overall"]
    assert row["errors"] == ["no cycle (test)"]
    for key in ("mean_cycle_s", "cycles_per_min", "ratio_to_optimal", "ratio_to_optimal_max",
                "ik_ms_mean", "ik_ms_p95", "ik_iterations_mean"):
        assert row[key] is None, key
    for key in ("mean_cycle_s", "cycles_per_min", "ratio_to_optimal", "ik_ms_mean"):
        assert overall[key] is None, key

    assert pick.main(["--kinds", "bolt", "--poses", "1"]) == 0
    table = capsys.readouterr().out
    assert "nan" not in table.lower()
    bolt = next(ln for ln in table.splitlines() if ln.startswith("bolt "))
    assert bolt.split()[2:] == ["-"] * 7, bolt


def _empty_stats(presets=("front",)) -> dict:
    """A run's statistics where a frame was detected but no part was matched."""
    return {p: Tally(false=2, missed=1, latency=[0.004], render=[0.0], per_part=[0.004])
            for p in presets}


def test_vision_figures_with_no_samples_are_null_and_dash(capsys):
    report = summarise(_empty_stats(), scenes=1, seed_base=vision.SEED_BASE, parts=1)
    row = report["presets"]["front"]
    for key in ("position_p50_mm", "position_p95_mm", "yaw_p95_deg", "repeat_latency_ms",
                "latency_over_render", "material_accuracy", "kind_accuracy"):  # (0.0 before)
        assert row[key] is None, key
    assert row["latency_ms"] == pytest.approx(4.0)
    _strict_json(json.dumps(report, allow_nan=False))
    vision._print(report)
    table = capsys.readouterr().out
    assert "nan" not in table.lower()
    line = next(ln for ln in table.splitlines() if ln.startswith("front "))
    assert line.split()[6:9] == ["-", "-", "-"], line  # p50mm, p95mm, yaw95


def test_vision_smallest_run_json_is_strict(capsys):
    assert vision.main(["--scenes", "1", "--parts", "1", "--presets", "front", "--json"]) == 0
    report = _strict_json(capsys.readouterr().out)
    assert report["scenes_per_preset"] == 1 and list(report["presets"]) == ["front"]


def test_fmt_prints_a_dash_of_the_same_width():
    from cell.benchmarks import fmt

    assert fmt(None, ">8.3f") == "       -" and fmt(float("nan"), ".1f") == "-"
    assert fmt(1.5, ">6.2f") == "  1.50"


def test_bench_help_lists_every_benchmark_and_its_options():
    r = _cell("bench", "--help")
    assert r.returncode == 0 and r.stderr == ""
    for name in ("render", "vision", "pick"):
        assert f"usage: cell bench {name}" in r.stdout, name
    for option in ("--repeats", "--scenes", "--seed-base", "--parts", "--presets", "--cold",
                   "--poses", "--pose-noise-mm", "--yaw-noise-deg", "--kinds"):
        assert option in r.stdout, option
    assert "cell bench NAME --help" in r.stdout and "``" not in r.stdout


def test_bench_with_no_name_prints_usage_to_stderr_and_exits_2():
    r = _cell("bench")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.startswith("usage: cell bench ") and "error: name a benchmark" in r.stderr
    r = _cell("bench", "fly")
    assert r.returncode == 2 and r.stdout == "" and "valid: render, vision, pick" in r.stderr


def test_vision_recall_is_found_over_found_and_missed():
    stats = {"front": Tally(n=8, material_ok=6, kind_ok=7, false=5, missed=2, latency=[0.004],
                            render=[0.002], per_part=[0.001])}
    row = summarise(stats, scenes=1, seed_base=0, parts=10)["presets"]["front"]
    assert row["recall"] == pytest.approx(0.8)  # 8 of the 10 parts; the 5 false ones do not count
    assert row["material_accuracy"] == pytest.approx(0.75) and row["kind_accuracy"] == pytest.approx(0.875)
    assert row["false"] == 5 and row["missed"] == 2


def test_the_vision_bench_scores_a_part_from_30_visible_pixels():
    """A part with 40 pixels in view that no detection matched is missed; one with 20 (a
    sliver behind the arm's shadow, say) is not counted; a part at the image border that a
    partial detection matched is a partial told right; a second detection of one part is false."""
    from types import SimpleNamespace

    import numpy as np

    from cell.benchmarks.vision_score import score_frame

    seg = np.zeros((48, 64), np.int32)
    seg[10:15, 10:18] = 1  # 40 px, missed
    seg[30:34, 30:35] = 2  # 20 px, too few to count
    seg[0:6, 50:60] = 3  # 60 px at the top border
    parts = [SimpleNamespace(kind="washer", material="metal", finish="steel")] * 3
    world = SimpleNamespace(parts=parts, part_pose=lambda pid: (np.zeros(3), None),
                            part_yaw=lambda pid: 0.0)
    border = SimpleNamespace(centroid=(54.5, 2.5), partial=True, kind="unknown", material="metal",
                             position=None, yaw=0.0)
    stats = Tally()
    score_frame(world, seg, [border, border], stats)
    assert (stats.missed, stats.n, stats.partial_ok, stats.false) == (1, 0, 1, 1)
