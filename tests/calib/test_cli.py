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
