"""`cell calibrate`'s output options: refused before any work when they cannot be written."""

from __future__ import annotations

import pytest

from cell.cli import main as cell_main


@pytest.mark.parametrize(("report", "culprit"), [
    ("sub/../c.json", "--out 'c.json' and --report 'sub/../c.json' are the same file"),
    ("", "--report: empty path"),
])
def test_a_report_on_the_calibration_or_empty_is_refused(capsys, monkeypatch, tmp_path, report, culprit):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    assert cell_main(["calibrate", "--poses", "3", "--no-touch", "--out", "c.json", "--report", report]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert culprit in line, line
    assert [p.name for p in tmp_path.iterdir()] == ["sub"]


@pytest.mark.parametrize(("camera", "setting", "board"), [
    ("wrist", "calibration.board_inner_corners=[3,4]", "8x5 inner corners of 0.025 m"),
    ("wrist", "calibration.board_square=0.001", "8x5 inner corners of 0.025 m"),
    ("overhead", "calibration.flange_board_inner_corners=[3,4]", "8x5 inner corners of 0.015 m"),
])
def test_a_board_the_cell_does_not_hold_is_refused_first(capsys, tmp_path, camera, setting, board):
    # (OpenCV crashed the command, or a 1 mm square calibrated a camera 300 mm off, exit 0)
    args = ["calibrate", "--camera", camera, "--set", setting, "--out", str(tmp_path / "c.json")]
    assert cell_main(args) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert setting.split("=")[0] in line and board in line, line
    assert list(tmp_path.iterdir()) == []
