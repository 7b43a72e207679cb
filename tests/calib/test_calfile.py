"""Calibration files: round trip, atomic writes, and a clear error for every bad edit."""

from __future__ import annotations

import copy
import json
import math
import os
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import cell.calib.calfile as calfile
from cell.calib.calfile import CalibrationFile, calibration_from_dict, load_calibration, write_calibration
from cell.camera import CameraModel
from cell.errors import CalibrationError
from tests.calib.synthetic import K_TRUE, X_TRUE, calibration_entry, calibration_file


def _valid() -> dict:
    return calibration_file().to_dict()


def _with(path: tuple, value) -> dict:
    data = copy.deepcopy(_valid())
    *head, last = path
    node = data
    for key in head:
        node = node[key]
    if value is _DELETE:
        del node[last]
    else:
        node[last] = value
    return data


_DELETE = object()
_CAM = ("cameras", 0)

BAD = [
    ("missing field", _with((*_CAM, "rms"), _DELETE), r"cameras\[0\] \('wrist'\): missing key 'rms'"),
    ("missing pose", _with((*_CAM, "T_flange_camera"), _DELETE),
     r"missing key 'T_flange_camera or T_base_camera'"),
    ("wrong shape", _with((*_CAM, "K"), [[515.0, 0, 320], [0, 515, 240]]),
     r"'K' must be 3x3, got shape \(2, 3\)"),
    ("NaN", _with((*_CAM, "dist", 1), math.nan), r"'dist\[1\]' must be finite, got nan"),
    ("not orthonormal", _with((*_CAM, "T_flange_camera", 0, 0), 0.9),
     r"'T_flange_camera' rotation \(top-left 3x3\) is not orthonormal"),
    ("reflection", _with((*_CAM, "T_flange_camera"), np.diag([1.0, 1, -1, 1]).tolist()),
     r"'T_flange_camera' rotation \(top-left 3x3\) is a reflection"),
    ("zero focal", _with((*_CAM, "K", 1, 1), 0.0), r"'K\[1\]\[1\]' \(fy\) must be > 0"),
    ("negative focal", _with((*_CAM, "K", 0, 0), -515.0), r"'K\[0\]\[0\]' \(fx\) must be > 0"),
    ("huge focal", _with((*_CAM, "K", 0, 0), 1e300),
     r"'K\[0\]\[0\]' \(fx\) must be 0.64 to 640000 .*got 1e\+300"),
    ("huge distortion", _with((*_CAM, "dist", 2), -1e300), r"'dist\[2\]' must be -100 to 100 .*got -1e\+300"),
    ("far camera", _with((*_CAM, "T_flange_camera", 0, 3), 1e3),
     r"'T_flange_camera\[0\]\[3\]' must be -100 to 100 \(metres, the translation\), got 1000.0"),
    ("unknown version", _with(("version",), 2), r"unsupported 'version' 2: this cell reads version 1"),
    ("version as text", _with(("version",), "1"), r"unsupported 'version' '1'"),
    ("unknown schema", _with(("schema",), "other"), r"'schema' must be 'cell.calibration'"),
    ("no schema", _with(("schema",), _DELETE), r"missing key 'schema'"),
    ("negative rms", _with((*_CAM, "rms"), -0.1), r"'rms' must be a finite number >= 0"),
    ("boolean rms", _with((*_CAM, "rms"), True), r"'rms' must be a finite number >= 0"),
    ("negative seed", _with((*_CAM, "seed"), -1), r"'seed' must be an integer >= 0"),
    ("empty method", _with((*_CAM, "method"), ""), r"'method' must be printable text"),
    ("escape in name", _with((*_CAM, "name"), "w\x1b[2J"), r"name must be printable text"),
    ("typo key", _with((*_CAM, "T_flange_cam"), X_TRUE.tolist()), r"unknown key 'T_flange_cam'"),
    ("width as text", _with((*_CAM, "width"), "640"), r"'width' must be an integer"),
    ("cameras not a list", _with(("cameras",), {}), r"'cameras' must be a list"),
    ("no camera", _with(("cameras",), []), r"at least one camera"),
]


@pytest.mark.parametrize(("what", "data", "pattern"), BAD, ids=[b[0] for b in BAD])
def test_a_bad_file_names_the_problem(tmp_path, what, data, pattern):
    path = tmp_path / "calib.json"
    path.write_text(json.dumps(data))
    where = re.escape(repr(str(path)))
    with pytest.raises(CalibrationError, match=f"^calibration file {where}: .*{pattern}"):
        load_calibration(path)


def test_both_poses_and_duplicate_names_are_refused():
    data = _with((*_CAM, "T_base_camera"), np.eye(4).tolist())
    with pytest.raises(CalibrationError, match="has both T_flange_camera and T_base_camera"):
        calibration_from_dict(data)
    data = _valid()
    data["cameras"].append(copy.deepcopy(data["cameras"][0]))
    with pytest.raises(CalibrationError, match="camera 'wrist' appears more than once"):
        calibration_from_dict(data)


def test_unreadable_files_are_calibration_errors(tmp_path):
    with pytest.raises(CalibrationError, match="no such calibration file"):
        load_calibration(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{ not json")
    with pytest.raises(CalibrationError, match="not valid JSON"):
        load_calibration(tmp_path / "bad.json")


def test_the_file_round_trips(tmp_path):
    path = tmp_path / "calib.json"
    write_calibration(path, calibration_file())
    back = load_calibration(path)
    assert back.to_dict() == calibration_file().to_dict()
    cam = back.camera("wrist")
    assert np.allclose(cam.K, K_TRUE) and np.allclose(cam.pose, X_TRUE)
    text = path.read_text()
    assert json.loads(text)["schema"] == "cell.calibration" and "NaN" not in text
    assert os.listdir(tmp_path) == ["calib.json"]  # no temporary file left behind


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "calib.json"
    write_calibration(path, calibration_file())
    before = path.read_bytes()
    bad = CalibrationFile((calibration_entry(),))
    object.__setattr__(bad.cameras[0], "rms", float("nan"))  # a corrupted object cannot be written
    with pytest.raises(ValueError):
        write_calibration(path, bad)
    assert path.read_bytes() == before and os.listdir(tmp_path) == ["calib.json"]
    with pytest.raises(CalibrationError, match="cannot write calibration file"):
        write_calibration(tmp_path / "no" / "calib.json", calibration_file())


def test_camera_models_from_the_file(tmp_path):
    path = tmp_path / "calib.json"
    overhead = calibration_entry(name="overhead", pose_name="T_base_camera", pose=np.diag([1.0, -1, -1, 1]))
    write_calibration(path, CalibrationFile((calibration_entry(), overhead)))
    model = CameraModel.from_calibration(path, "overhead")
    assert model.T_world_camera == pytest.approx(np.diag([1.0, -1, -1, 1]))
    with pytest.raises(CalibrationError, match="rides on the arm .* needs the flange pose"):
        CameraModel.from_calibration(path, "wrist")
    T_base_flange = np.eye(4)
    T_base_flange[:3, 3] = [0.4, 0.1, 0.5]
    wrist = CameraModel.from_calibration(path, "wrist", T_base_flange=T_base_flange)
    assert wrist.T_world_camera == pytest.approx(T_base_flange @ X_TRUE)
    with pytest.raises(CalibrationError, match="no camera 'side' in the calibration; it has: wrist, overhe"):
        CameraModel.from_calibration(path, "side")


# --- property: any edit of a valid file loads as valid data or fails with a clear error ---

_leaves = st.one_of(
    st.none(), st.booleans(), st.integers(-10**6, 10**6), st.sampled_from([10**400, -(10**400)]),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
    st.lists(st.floats(-2, 2), max_size=5), st.dictionaries(st.text(max_size=4), st.integers(), max_size=2),
)


def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, (*prefix, i))


_ALL_PATHS = [p for p in _paths(_valid()) if p]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.sampled_from(_ALL_PATHS), st.one_of(_leaves, st.just(_DELETE))),
                min_size=1, max_size=3))
def test_any_edit_loads_as_valid_data_or_names_the_problem(edits):
    data = _valid()
    for path, value in edits:
        node = data
        try:
            for key in path[:-1]:
                node = node[key]
            if value is _DELETE:
                del node[path[-1]]
            else:
                node[path[-1]] = value
        except (KeyError, IndexError, TypeError):
            continue  # an earlier edit removed or replaced this path
    try:
        calib = calibration_from_dict(data, where="edited")
    except CalibrationError as exc:
        message = str(exc)
        assert message.startswith("edited: ") and message.isprintable() and len(message) < 400
        return
    for cam in calib.cameras:  # accepted: every field is valid
        assert np.isfinite(cam.K).all() and cam.K[0, 0] > 0 and cam.K[1, 1] > 0
        R = cam.pose[:3, :3]
        assert np.abs(R.T @ R - np.eye(3)).max() < 1e-5 and np.linalg.det(R) > 0
        assert math.isfinite(cam.rms) and cam.rms >= 0


def test_a_fixed_camera_refuses_a_flange_pose(tmp_path):
    path = tmp_path / "calib.json"
    overhead = calibration_entry(name="overhead", pose_name="T_base_camera", pose=np.diag([1.0, -1, -1, 1]))
    write_calibration(path, CalibrationFile((calibration_entry(), overhead)))
    T_base_flange = np.eye(4)
    T_base_flange[:3, 3] = [0.4, 0.1, 0.5]
    with pytest.raises(CalibrationError, match="camera 'overhead' is fixed .* takes no flange pose"):
        CameraModel.from_calibration(path, "overhead", T_base_flange=T_base_flange)


def test_a_file_that_reads_back_differently_is_not_written(tmp_path, monkeypatch):
    path = tmp_path / "calib.json"
    write_calibration(path, calibration_file())
    before = path.read_bytes()
    other = CalibrationFile((calibration_entry(rms=0.5),))
    monkeypatch.setattr(calfile, "load_calibration", lambda _tmp: other)  # the disk gave back other bytes
    with pytest.raises(CalibrationError, match="the written file reads back differently"):
        write_calibration(path, calibration_file())
    assert path.read_bytes() == before and os.listdir(tmp_path) == ["calib.json"]
