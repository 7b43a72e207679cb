"""``CameraModel``: every field checked when made, in code or from ``camera.json``."""

from __future__ import annotations

import copy
import dataclasses
import itertools
import json
import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cell.camera import MAX_SIDE, TOLERANCE, CameraModel
from cell.errors import CalibrationError, CellError

FIELDS = ("width", "height", "K", "dist", "T_world_camera")
F = 659.3945806691094


def _valid() -> dict:
    """The overhead camera of ``cell snapshot scenarios/sort.toml`` (its camera.json)."""
    return {
        "width": 640,
        "height": 480,
        "K": [[F, 0.0, 319.5], [0.0, F, 239.5], [0.0, 0.0, 1.0]],
        "dist": [0.0] * 5,
        "T_world_camera": [[1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.45],
                           [0.0, 0.0, -1.0, 0.48], [0.0, 0.0, 0.0, 1.0]],
    }


def _with(path: tuple, value) -> dict:
    data = copy.deepcopy(_valid())
    *head, last = path
    node = data
    for key in head:
        node = node[key]
    node[last] = value
    return data


def _quoted(path) -> str:
    return re.escape(repr(str(path)))


def _rotated(R) -> list:
    T = np.array(_valid()["T_world_camera"])
    T[:3, :3] = R
    return T.tolist()


_FLIP = np.diag([1.0, -1.0, -1.0])  # the valid rotation

# (what is wrong, the model's dict, a pattern its message must match)
BAD = [
    ("NaN fx", _with(("K", 0, 0), math.nan), r"'K\[0\]\[0\]' \(fx\) must be finite, got nan"),
    ("zero fx", _with(("K", 0, 0), 0.0), r"'K\[0\]\[0\]' \(fx\) must be > 0"),
    ("negative fy", _with(("K", 1, 1), -F), r"'K\[1\]\[1\]' \(fy\) must be > 0"),
    ("infinite cx", _with(("K", 0, 2), math.inf), r"'K\[0\]\[2\]' \(cx\) must be finite"),
    ("K = 1..9", _with(("K",), [[1, 2, 3], [4, 5, 6], [7, 8, 9]]), r"'K\[2\]' \(bottom row\).*\[7, 8, 9\]"),
    ("K lower part", _with(("K", 1, 0), 3.0), r"'K\[1\]\[0\]' must be 0"),
    ("K 2x2", _with(("K",), [[F, 0], [0, F]]), r"'K' must be 3x3, got shape \(2, 2\)"),
    ("K ragged", _with(("K", 1), [0.0, F]), r"'K' must be 3x3, got rows of lengths \[3, 2, 3\]"),
    ("K a string", _with(("K", 0, 1), "0"), r"'K\[0\]\[1\]' \(skew\) must be a number, got '0'"),
    ("K a null", _with(("K", 2, 0), None), r"'K\[2\]\[0\]' must be a number, got None"),
    ("K a boolean", _with(("K", 2, 2), True), r"'K\[2\]\[2\]' must be a number, got True"),
    ("K 401 digits", _with(("K", 0, 0), 10**400), r"'K\[0\]\[0\]' \(fx\) must be finite"),
    ("K an object", _with(("K",), {"fx": F}), r"'K' must be 3x3 \(a list\), got an object"),
    ("reflection", _with(("T_world_camera",), _rotated(np.diag([1.0, -1.0, 1.0]))),
     r"'T_world_camera' rotation .* is a reflection: det = -1"),
    ("mirrored axis", _with(("T_world_camera", 0, 0), -1.0), r"'T_world_camera' rotation .* reflection"),
    ("scaled rotation", _with(("T_world_camera",), _rotated(1.01 * _FLIP)),
     r"'T_world_camera' rotation .* not orthonormal: max \|R\^T R - I\| = 0.0201, tolerance 1e-06"),
    ("sheared rotation", _with(("T_world_camera", 0, 1), 0.2),
     r"'T_world_camera' rotation .* not orthonormal"),
    ("huge rotation", _with(("T_world_camera", 1), [1e308, -1e308, 1e308, 0.0]),
     r"'T_world_camera' rotation .* not orthonormal: max \|R\^T R - I\| = (inf|nan)"),
    ("T bottom row", _with(("T_world_camera", 3), [0.0, 0.0, 0.5, 1.0]),
     r"'T_world_camera\[3\]' \(bottom row\) must be \[0, 0, 0, 1\], got \[0, 0, 0.5, 1\]"),
    ("T NaN position", _with(("T_world_camera", 2, 3), math.nan),
     r"'T_world_camera\[2\]\[3\]' must be finite"),
    ("T 3x4", _with(("T_world_camera",), _valid()["T_world_camera"][:3]), r"'T_world_camera' must be 4x4"),
    ("dist 4", _with(("dist",), [0.0] * 4), r"'dist' must be 5 numbers, got shape \(4,\)"),
    ("dist inf", _with(("dist", 4), -math.inf), r"'dist\[4\]' must be finite, got -inf"),
    ("dist a string", _with(("dist",), "none"), r"'dist' must be 5 numbers \(a list\), got a string"),
    ("fractional width", _with(("width",), 640.5), r"'width' must be an integer in 1..65536 .*got 640.5"),
    ("float width", _with(("width",), 640.0), r"'width' must be an integer"),
    ("zero height", _with(("height",), 0), r"'height' must be an integer in 1..65536"),
    ("negative width", _with(("width",), -640), r"'width' must be an integer"),
    ("huge width", _with(("width",), MAX_SIDE + 1), r"'width' must be an integer"),
    ("boolean height", _with(("height",), True), r"'height' must be an integer"),
    ("string width", _with(("width",), "640"), r"'width' must be an integer .*got '640'"),
    ("no K", {k: v for k, v in _valid().items() if k != "K"}, r"missing key 'K'"),
    # finite but out of range (each crashed or warned in `cell detect` before it was refused)
    ("huge fx", _with(("K", 0, 0), 1e300),
     r"'K\[0\]\[0\]' \(fx\) must be 0.64 to 640000 \(pixels: 0.001 to 1000 times the larger of "
     r"'width' 640 and 'height' 480\), got 1e\+300"),
    ("tiny fx", _with(("K", 0, 0), 1e-300), r"'K\[0\]\[0\]' \(fx\) must be 0.64 to 640000 .*got 1e-300"),
    ("huge fy", _with(("K", 1, 1), 1e7), r"'K\[1\]\[1\]' \(fy\) must be 0.64 to 640000 .*got 10000000.0"),
    ("huge cx", _with(("K", 0, 2), 1e300),
     r"'K\[0\]\[2\]' \(cx\) must be -640 to 1280 \(pixels: -1 to 2 times 'width' 640\), got 1e\+300"),
    ("cy far above", _with(("K", 1, 2), -481.0),
     r"'K\[1\]\[2\]' \(cy\) must be -480 to 960 \(pixels: -1 to 2 times 'height' 480\), got -481.0"),
    ("huge skew", _with(("K", 0, 1), -1e300), r"'K\[0\]\[1\]' \(skew\) must be 0 .*got -1e\+300"),
    ("any skew", _with(("K", 0, 1), 5.0), r"'K\[0\]\[1\]' \(skew\) must be 0 \(OpenCV's camera model"),
    ("huge distortion", _with(("dist", 2), -1e300),
     r"'dist\[2\]' must be -100 to 100 \(k1, k2, p1, p2, k3 each\), got -1e\+300"),
    ("large k3", _with(("dist", 4), 100.5), r"'dist\[4\]' must be -100 to 100 .*got 100.5"),
    ("far camera", _with(("T_world_camera", 0, 3), 1e300),
     r"'T_world_camera\[0\]\[3\]' must be -100 to 100 \(metres, the translation\), got 1e\+300"),
    ("deep camera", _with(("T_world_camera", 2, 3), -100.01),
     r"'T_world_camera\[2\]\[3\]' must be -100 to 100"),
]


@pytest.mark.parametrize(("data", "pattern"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_invalid_content_is_an_error_naming_the_field(data, pattern, tmp_path):
    with pytest.raises(CalibrationError, match=f"^camera model: {pattern}"):
        CameraModel.from_dict(data)
    path = tmp_path / "camera.json"
    path.write_text(json.dumps(data))  # NaN and 10**400 as Python's json writes them
    with pytest.raises(CalibrationError, match=f"^camera file {_quoted(path)}: {pattern}"):
        CameraModel.load(path)


def test_the_constructor_checks_too():
    v = _valid()
    with pytest.raises(CalibrationError, match=r"^CameraModel: 'K\[0\]\[0\]' \(fx\) must be > 0"):
        CameraModel(640, 480, np.diag([-1.0, 1.0, 1.0]), np.zeros(5), np.array(v["T_world_camera"]))
    with pytest.raises(CalibrationError, match=r"'K' must hold real numbers, got dtype bool"):
        CameraModel(640, 480, np.eye(3, dtype=bool), np.zeros(5), np.eye(4))
    with pytest.raises(CalibrationError, match=r"'width' must be an integer"):
        CameraModel(np.float64(640), 480, np.array(v["K"]), np.zeros(5), np.eye(4))
    cam = CameraModel(np.int64(640), 480, np.array(v["K"]), np.zeros((1, 5)), np.eye(4))  # OpenCV's dist
    assert type(cam.width) is int and cam.dist.shape == (5,)


EDGES = [  # each range's ends are inside it
    ("K", 0, 0, 0.64), ("K", 1, 1, 640000.0), ("K", 0, 2, -640.0), ("K", 0, 2, 1280.0),
    ("K", 1, 2, -480.0), ("K", 1, 2, 960.0), ("K", 0, 1, 0.0),
    ("dist", 0, -100.0), ("dist", 3, 100.0),
    ("T_world_camera", 0, 3, -100.0), ("T_world_camera", 2, 3, 100.0),
]


@pytest.mark.parametrize("edge", EDGES, ids=[str(e) for e in EDGES])
def test_the_ends_of_each_range_are_valid(edge):
    *path, value = edge
    model = CameraModel.from_dict(_with(tuple(path), value))
    assert model.to_dict() == CameraModel.from_dict(model.to_dict()).to_dict()


def _scenario_bounds(cls, name: str) -> tuple:
    meta = {f.name: f.metadata for f in dataclasses.fields(cls)}[name]
    return meta["lo"], meta["hi"]


def test_every_camera_a_scenario_can_make_is_valid():
    """The simulator's cameras (``true_camera_model``: f from the field of view, the
    principal point at the centre) at the ends of the scenario's ranges, the wrist camera's
    lens too, with the widest distortion, and poses from the cell's layout."""
    from cell.scenario import CameraSettings, SensorSettings

    sides = _scenario_bounds(CameraSettings, "width")
    fovys = (*_scenario_bounds(CameraSettings, "fovy"), 50.0)  # 50: the wrist camera's
    k = max(abs(b) for b in _scenario_bounds(SensorSettings, "distortion"))
    for (w, h), fovy, sign in itertools.product(itertools.product(sides, sides), fovys, (-1, 1)):
        f = 0.5 * h / math.tan(math.radians(fovy) / 2)
        K = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1]])
        CameraModel(w, h, K, np.full(5, sign * k), np.array(_valid()["T_world_camera"]))


def test_rotation_tolerance_is_as_stated():
    R = _FLIP.copy()
    R[0, 0] = 1.0 + 0.4 * TOLERANCE  # |R^T R - I| = 0.8e-6: inside
    CameraModel.from_dict(_with(("T_world_camera",), _rotated(R)))
    R[0, 0] = 1.0 + 0.6 * TOLERANCE  # 1.2e-6: outside
    with pytest.raises(CalibrationError, match="not orthonormal"):
        CameraModel.from_dict(_with(("T_world_camera",), _rotated(R)))


def test_a_valid_file_round_trips(tmp_path):
    path = tmp_path / "camera.json"
    path.write_text("\ufeff" + json.dumps({**_valid(), "note": "extra keys are ignored"}))  # BOM ok
    cam = CameraModel.load(path)
    assert cam.to_dict() == _valid()
    cam.save(tmp_path / "again.json")
    assert CameraModel.load(tmp_path / "again.json").to_dict() == _valid()
    del_dist = {k: v for k, v in _valid().items() if k != "dist"}
    assert CameraModel.from_dict(del_dist).dist.tolist() == [0.0] * 5



def test_save_is_whole_or_absent_and_names_the_path(tmp_path):
    cam = CameraModel.from_dict(_valid())
    (tmp_path / "taken").mkdir()
    with pytest.raises(CalibrationError, match="camera file .*taken"):
        cam.save(tmp_path / "taken")  # a folder: os.replace fails, no file left behind
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]
    assert list((tmp_path / "taken").iterdir()) == []


FILES = [
    ("null", b"null", r"expected a JSON object with keys width, height, K, T_world_camera .*got null"),
    ("a number", b"42", r"expected a JSON object .*got a number 42"),
    ("a list", b"[1, 2]", r"expected a JSON object .*got a list"),
    ("a string", b'"camera"', r"expected a JSON object .*got a string"),
    ("binary", bytes(range(256)), r"not UTF-8 text \(byte 0x80 at offset 128\)"),
    ("Latin-1", '{"width": "640 \u00b5m"}'.encode("latin-1"), r"not UTF-8 text \(byte 0xb5 at offset 15\)"),
    ("not JSON", b"width = 640\n", r"not valid JSON: Expecting value \(line 1, column 1\)"),
    ("empty", b"", r"not valid JSON"),
    ("5000 digits", b"[" + b"9" * 5000 + b"]", r"not valid JSON"),
    ("nested deep", b"[" * 100_000 + b"]" * 100_000, r"not valid JSON"),
]


@pytest.mark.parametrize(("content", "pattern"), [f[1:] for f in FILES], ids=[f[0] for f in FILES])
def test_unusable_files_are_one_error_naming_the_file(content, pattern, tmp_path):
    path = tmp_path / "camera.json"
    path.write_bytes(content)
    with pytest.raises(CalibrationError, match=f"^camera file {_quoted(path)}: {pattern}"):
        CameraModel.load(path)


def test_missing_or_directory_or_escaped_paths(tmp_path):
    missing = _quoted(tmp_path / "none.json")
    with pytest.raises(CalibrationError, match=f"^camera file {missing}: no such camera file$"):
        CameraModel.load(tmp_path / "none.json")
    with pytest.raises(CalibrationError, match=f"^camera file {_quoted(tmp_path)}: is a directory"):
        CameraModel.load(tmp_path)
    with pytest.raises(CalibrationError) as err:
        CameraModel.load(tmp_path / "a\x1b]0;owned\x07.json")
    assert "\x1b" not in str(err.value) and "\x07" not in str(err.value)
    assert r"a\x1b]0;owned\x07.json" in str(err.value)


# --- property: random camera.json contents load as a valid model or one CellError -------------

_LEAVES = (st.none() | st.booleans() | st.integers(min_value=-10**500, max_value=10**500)
           | st.floats() | st.text(max_size=8))
_JSON = st.recursive(_LEAVES, lambda inner: st.lists(inner, max_size=5)
                     | st.dictionaries(st.sampled_from(FIELDS) | st.text(max_size=4), inner, max_size=6),
                     max_leaves=30)
_ODD = st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, -1.0, 0, 0.5, 10**400, -(10**400),
                        "1", "", None, True, False, [], [[]], {}, [1.0] * 5, [[1.0] * 4] * 4])


@st.composite
def _near_valid(draw) -> tuple[dict, str]:
    """A valid model with one field (or one element or row of it) replaced or removed."""
    data = _valid()
    key = draw(st.sampled_from(FIELDS))
    if draw(st.integers(0, 9)) == 0:
        del data[key]
        return data, key
    path = [key]
    node = data[key]
    while isinstance(node, list) and draw(st.booleans()):
        path.append(draw(st.integers(0, len(node) - 1)))
        node = node[path[-1]]
    return _with(tuple(path), draw(_ODD | _JSON | st.floats())), key


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("hypothesis") / "camera.json"


def _load_or_error(path) -> CameraModel | CellError:
    try:
        return CameraModel.load(path)
    except CellError as exc:  # any other exception fails the test
        assert str(exc).startswith(f"camera file {str(path)!r}: "), str(exc)
        assert "\n" not in str(exc)
        return exc


_HYPO = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@_HYPO
@given(value=_JSON)
def test_random_json_loads_as_a_model_or_a_cell_error(value, scratch):
    scratch.write_text(json.dumps(value))
    out = _load_or_error(scratch)
    if isinstance(out, CellError):
        assert any(name in str(out) for name in FIELDS) or "expected a JSON object" in str(out)


@_HYPO
@given(case=_near_valid())
def test_near_valid_models_name_the_perturbed_field(case, scratch):
    data, key = case
    scratch.write_text(json.dumps(data))
    out = _load_or_error(scratch)
    if isinstance(out, CameraModel):
        assert CameraModel.from_dict(out.to_dict()).to_dict() == out.to_dict()
        values = np.concatenate([out.K.ravel(), out.dist, out.T_world_camera.ravel()])
        assert np.isfinite(values).all()
    else:
        assert f"'{key}" in str(out), str(out)


@_HYPO
@given(content=st.binary(max_size=64))
def test_random_bytes_are_a_cell_error(content, scratch):
    scratch.write_bytes(content)
    assert isinstance(_load_or_error(scratch), CellError)
