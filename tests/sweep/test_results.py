"""results.csv and the output folder: rows written whole and durably, read back for
--resume (a half-written last row dropped, a foreign or damaged file refused), values
round-trip, and the output folder's rules."""

from __future__ import annotations

import math

import pytest

from cell.sweep.errors import SweepError
from cell.sweep.output import prepare_out, remove_temporaries, write_atomic
from cell.sweep.results import format_value, open_results, parse_value, read_rows

COLUMNS = ("run_id", "job", "seed", "lighting", "recall", "error")
KNOWN = {"a" * 16, "b" * 16, "c" * 16}


def _row(rid: str, **kw) -> dict:
    return {"run_id": rid, "job": "detect", "seed": 1, "lighting": "front", "recall": 0.5, **kw}


def test_values_round_trip_and_nan_is_refused():
    for value in (None, True, False, 3, -7, 0.1, 1e-300, "front", "a, b", (1.0, 2.5), ("back", "front")):
        assert parse_value(format_value(value)) == value, value
    with pytest.raises(ValueError):
        format_value(math.nan)
    assert parse_value("nan") is None and parse_value("inf") is None


def test_a_nan_figure_is_refused_naming_its_run_and_column(tmp_path):
    path = tmp_path / "results.csv"
    results, _ = open_results(path, COLUMNS, KNOWN)
    with pytest.raises(SweepError, match=r"run a{16}, column 'recall': a figure is NaN"):
        results.append(_row("a" * 16, recall=math.inf))
    results.close()
    assert path.read_text().count("\n") == 1  # the header only


def test_rows_are_appended_and_read_back(tmp_path):
    path = tmp_path / "results.csv"
    results, cut = open_results(path, COLUMNS, KNOWN)
    assert cut == 0 and results.done == set()
    results.append(_row("a" * 16))
    results.append(_row("b" * 16, recall=None, error="a run failed, politely"))
    results.close()
    header, rows = read_rows(path)
    assert header == COLUMNS and [r["run_id"] for r in rows] == ["a" * 16, "b" * 16]
    assert rows[1]["recall"] is None and rows[1]["error"] == "a run failed, politely"
    again, cut = open_results(path, COLUMNS, KNOWN)
    assert again.done == {"a" * 16, "b" * 16} and cut == 0
    again.close()


def test_a_half_written_last_row_is_cut_off_on_resume(tmp_path):
    path = tmp_path / "results.csv"
    results, _ = open_results(path, COLUMNS, KNOWN)
    results.append(_row("a" * 16))
    results.close()
    whole = path.read_bytes()
    path.write_bytes(whole + b"bbbbbbbbbbbbbbbb,detect,1,fr")  # the crash came mid-row
    results, cut = open_results(path, COLUMNS, KNOWN)
    assert cut == len(b"bbbbbbbbbbbbbbbb,detect,1,fr") and results.done == {"a" * 16}
    results.append(_row("b" * 16))
    results.close()
    assert path.read_bytes().count(b"\n") == 3 and read_rows(path)[1][1]["run_id"] == "b" * 16


@pytest.mark.parametrize(("content", "words"), [
    (b"run_id,job\n", "not this sweep's"),
    (",".join(COLUMNS).encode() + b"\n" + b"z" * 16 + b",detect,1,front,0.5,\n", "not a run of this sweep"),
    (",".join(COLUMNS).encode() + b"\n" + b"a" * 16 + b",detect,1,front,0.5,\n" + b"a" * 16
     + b",detect,1,front,0.5,\n", "repeats run"),
    (",".join(COLUMNS).encode() + b"\n" + b"a" * 16 + b",detect\n", "fields"),
    (b"\xff\xfe\x00\x01\n", "not UTF-8"),
])
def test_a_foreign_or_damaged_results_file_is_refused(tmp_path, content, words):
    path = tmp_path / "results.csv"
    path.write_bytes(content)
    with pytest.raises(SweepError, match=words) as info:
        open_results(path, COLUMNS, KNOWN)
    assert str(path) in str(info.value)


HEADER = ",".join(COLUMNS).encode() + b"\n"
ROW_A = b"a" * 16 + b",detect,1,front,0.5,\n"
NOT_HALF = "line 3 is an unfinished last line that is not the start of a row of this sweep"


@pytest.mark.parametrize(("content", "words"), [
    (b"\x7fELF\x02\x01\x01" + bytes(range(11, 256)) * 12, "line 1 is not a whole header"),  # binary
    (b"run_id,job,seed,lighting,recall,erro\xff", "line 1 is not a whole header"),
    (HEADER + ROW_A + b"\x7fELF\x02\x01\x01\x00\x00", NOT_HALF),
    (HEADER + ROW_A + b"b" * 16 + b",det\x00", NOT_HALF),
    (HEADER + ROW_A + b"zz,detect", NOT_HALF),
    (HEADER + ROW_A + b"a" * 16 + b",det", NOT_HALF),  # a run already done
    (HEADER + ROW_A + b"\xff" * 20, NOT_HALF),
    (HEADER + ROW_A + b"b" * 16 + b",detect,1,front,0.5,,,,", NOT_HALF),
])
def test_only_a_half_written_row_of_this_sweep_is_dropped(tmp_path, content, words):
    path = tmp_path / "results.csv"
    path.write_bytes(content)
    with pytest.raises(SweepError, match=words) as info:
        open_results(path, COLUMNS, KNOWN)
    assert str(path) in str(info.value) and path.read_bytes() == content  # left as it was


def test_a_half_written_header_or_a_row_cut_in_a_character_is_dropped(tmp_path):
    path = tmp_path / "results.csv"
    path.write_bytes(HEADER[:9])
    results, cut = open_results(path, COLUMNS, KNOWN)
    results.close()
    assert cut == 9 and path.read_bytes() == HEADER
    half = b"b" * 16 + b',detect,1,front,,"caf\xc3'  # a crash inside a UTF-8 'é'
    path.write_bytes(HEADER + half)
    results, cut = open_results(path, COLUMNS, KNOWN)
    results.close()
    assert cut == len(half) and results.done == set() and path.read_bytes() == HEADER


@pytest.mark.parametrize(("row", "words"), [
    (b"a" * 16 + b",detect,1,front,nan,\n", "line 2: column 'recall' holds 'nan', not a finite number"),
    (b"a" * 16 + b",detect,1,front,-inf,\n", "column 'recall' holds '-inf'"),
    (b"a" * 16 + b",detect,1,front,1e999,\n", "column 'recall' holds '1e999'"),
    (b"a" * 16 + b",detect,1,front,high,\n", "column 'recall' holds 'high'"),
    (b"a" * 16 + b",detect,x,front,0.5,\n", "column 'seed' holds 'x'"),
    (b"a" * 16 + b",det\x00ct,1,front,0.5,\n", r"line 2 holds a character that is not printable \('\\x00'\)"),
    (b"a" * 16 + b",detect,1,front,0.5,\x1b[2J\n", "line 2 holds a character that is not printable"),
])
def test_a_finished_row_with_a_figure_that_is_not_finite_or_a_control_character_is_refused(
        tmp_path, row, words):
    path = tmp_path / "results.csv"
    path.write_bytes(HEADER + row)
    with pytest.raises(SweepError, match=words) as info:
        open_results(path, COLUMNS, KNOWN, numbers=("seed", "recall"))
    assert str(path) in str(info.value) and "\x00" not in str(info.value) and "\x1b" not in str(info.value)


def test_rows_with_empty_figures_and_crlf_lines_are_accepted(tmp_path):
    path = tmp_path / "results.csv"
    path.write_bytes(HEADER.replace(b"\n", b"\r\n") + ROW_A.replace(b"0.5", b"").replace(b"\n", b"\r\n"))
    results, cut = open_results(path, COLUMNS, KNOWN)
    results.close()
    assert cut == 0 and results.done == {"a" * 16}


def test_the_output_folder_rules(tmp_path):
    out = tmp_path / "new" / "deeper"
    assert prepare_out(str(out), resume=False) == out and out.is_dir()
    (out / "results.csv").write_text("x\n")
    (out / ".summary.md.1234.tmp").write_text("half")
    with pytest.raises(SweepError, match="pass --resume"):
        prepare_out(str(out), resume=False)
    prepare_out(str(out), resume=True)
    assert (out / ".summary.md.1234.tmp").exists()  # removed only once results.csv is accepted
    remove_temporaries(out)
    assert not (out / ".summary.md.1234.tmp").exists() and (out / "results.csv").exists()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(SweepError, match="not sweep outputs .'notes.txt'"):
        prepare_out(str(out), resume=True)
    with pytest.raises(SweepError, match="not a folder"):
        prepare_out(str(out / "notes.txt"), resume=False)
    with pytest.raises(SweepError, match="empty path"):
        prepare_out("", resume=False)


def test_a_folder_that_cannot_be_written_is_refused_before_the_sweep(tmp_path, monkeypatch):
    """(A permission the file system denies: faked, as root may write anywhere.)"""
    import cell.sweep.output as output

    monkeypatch.setattr(output.os, "access", lambda path, mode: False)
    with pytest.raises(SweepError, match="cannot be written .no permission."):
        prepare_out(str(tmp_path / "out"), resume=False)


@pytest.mark.parametrize("name", ["results.csv", "metrics.png", "summary.md"])
def test_an_output_name_that_cannot_become_a_file_is_refused(tmp_path, name):
    out = tmp_path / "out"
    out.mkdir()
    (out / name).mkdir()
    files = ("results.csv", "metrics.png", "summary.md")
    with pytest.raises(SweepError, match=f"'{name}' is a folder, not a file") as info:
        prepare_out(str(out), resume=True, files=files)
    assert str(out) in str(info.value) and "results.csv, metrics.png, summary.md" in str(info.value)
    (out / name).rmdir()
    (out / name).symlink_to(tmp_path)
    with pytest.raises(SweepError, match=f"'{name}' is a link, not a file"):
        prepare_out(str(out), resume=True, files=files)
    assert sorted(p.name for p in out.iterdir()) == [name]  # nothing written


def test_atomic_writes_leave_no_temporary_file(tmp_path):
    write_atomic(tmp_path / "a.png", b"\x89PNG")
    write_atomic(tmp_path / "a.png", b"\x89PNG again")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]
    assert (tmp_path / "a.png").read_bytes() == b"\x89PNG again"


def test_one_sweep_at_a_time_writes_to_a_folder(tmp_path):
    # (two sweeps on one folder both ran every run: 67 rows for 40 runs, and --resume then
    # refused the file)
    from cell.sweep.output import sweep_lock

    busy = pytest.raises(SweepError, match="another cell sweep is writing there now")
    with sweep_lock(tmp_path), busy, sweep_lock(tmp_path):
        pass
    with sweep_lock(tmp_path):  # free again once the first is done
        pass
    assert list(tmp_path.iterdir()) == []  # (the folder itself is locked: no file made)


def test_results_closed_on_a_full_disk_raise_nothing_more(tmp_path, monkeypatch):
    # (the failed flush was retried by close() in the runner's finally: a bare OSError
    # traceback over the one-line SweepError)
    path = tmp_path / "results.csv"
    results, _ = open_results(path, COLUMNS, KNOWN)

    class _Full:
        def close(self):
            raise OSError(28, "No space left on device")

    real = results._file
    monkeypatch.setattr(results, "_file", _Full())
    results.close()
    real.close()


def test_a_file_system_without_locks_runs_the_sweep_as_before(tmp_path, monkeypatch):
    import fcntl

    from cell.sweep.output import sweep_lock

    def no_locks(fd, op):
        raise OSError(37, "No locks available")

    monkeypatch.setattr(fcntl, "flock", no_locks)
    with sweep_lock(tmp_path):
        pass
