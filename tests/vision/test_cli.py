"""`cell detect IMAGE --camera camera.json`: reads a snapshot's files, prints detections."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import struct
import subprocess
import sys
import zlib

import cv2
import numpy as np
import pytest

from cell.cli import main as cell_main
from cell.sim import layout
from cell.vision.cli import MAX_PIXELS, main
from cell.vision.detector import PartDetector


@pytest.fixture(scope="module")
def snapshot(module_world_factory, tmp_path_factory):
    w = module_world_factory(seed=31, parts={"count": 2, "kinds": ["disc"],
                                             "materials": ["plastic_red"]})
    w.place_next_part(layout.PICK_ZONE[0] - 0.05, layout.PICK_ZONE[1], 0.0)
    w.place_next_part(layout.PICK_ZONE[0] + 0.05, layout.PICK_ZONE[1], 0.0)
    w.step(50)
    frame = w.render(depth=False, seg=False)
    out = tmp_path_factory.mktemp("snap")
    cv2.imwrite(str(out / "rgb.png"), cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
    frame.camera.save(out / "camera.json")
    (out / "truth.json").write_text(json.dumps(sorted(w.part_pose(p.id)[0][0] for p in w.parts)))
    return out


def test_json_lists_the_parts(snapshot, capsys):
    assert main([str(snapshot / "rgb.png"), "--camera", str(snapshot / "camera.json"),
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    dets = out["detections"]
    assert [d["kind"] for d in dets] == ["disc", "disc"]
    assert all(d["material"] == "plastic" for d in dets)
    xs = sorted(d["position"][0] for d in dets)
    truth = json.loads((snapshot / "truth.json").read_text())  # the belt moved them a little
    assert xs == pytest.approx(truth, abs=1e-3)


def test_table_output_and_overrides(snapshot, capsys, tmp_path):
    scen = tmp_path / "s.toml"
    scen.write_text("[vision]\nsegmentation = \"belt\"\nbelt_floor = 30\n")
    args = [str(snapshot / "rgb.png"), "--camera", str(snapshot / "camera.json"),
            "--scenario", str(scen), "--set", "smooth=5", "--set", "vision.noise_k=8"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "2 detection(s)" in text and text.count("disc") == 2


def test_errors_are_one_line_naming_the_culprit(snapshot, capsys, tmp_path):
    cam = str(snapshot / "camera.json")
    assert cell_main(["detect", str(tmp_path / "none.png"), "--camera", cam]) == 2
    assert "none.png" in capsys.readouterr().err
    assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera", cam,
                      "--set", "segmentation=magic"]) == 2
    err = capsys.readouterr().err
    assert "vision.segmentation" in err and "otsu" in err
    assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera",
                      str(tmp_path / "no.json")]) == 2
    assert "no.json" in capsys.readouterr().err


# --- hardening (issue 12): bad camera files, images and outputs are one error line, exit 2 ---


def _png_header(width: int, height: int) -> bytes:
    """A PNG that declares ``width`` x ``height`` RGB pixels but holds none: a size bomb's
    header in 57 bytes (decoding it would allocate width * height * 3 bytes)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")


def _one_error_line(capfd, *names: str) -> str:
    """The run's whole stderr (fd level: OpenCV's own logging included): one line naming each of
    ``names``, no traceback, nothing on stdout."""
    out, err = capfd.readouterr()
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("cell detect: error: "), err
    assert all(n in lines[0] for n in names), err
    return lines[0]


def _camera_variant(snapshot, tmp_path, **changes) -> str:
    data = json.loads((snapshot / "camera.json").read_text())
    data.update(changes)
    path = tmp_path / "camera.json"
    path.write_text(json.dumps(data))
    return str(path)


CAMERA_FILES = {
    "null": b"null",
    "a number": b"42",
    "a list": b"[[1, 0, 0], [0, 1, 0], [0, 0, 1]]",
    "binary": bytes(range(256)) * 4,
    "Latin-1": '{"width": 640, "note": "\u00b5m"}'.encode("latin-1"),
    "NaN literal": b'{"width": NaN}',
}


@pytest.mark.parametrize("content", CAMERA_FILES.values(), ids=CAMERA_FILES.keys())
def test_unusable_camera_files_exit_2_naming_the_file(content, snapshot, tmp_path, capfd):
    cam = tmp_path / "cam.json"
    cam.write_bytes(content)
    assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera", str(cam)]) == 2
    _one_error_line(capfd, f"camera file '{cam}'")


def test_camera_directory_or_missing_exit_2(snapshot, tmp_path, capfd):
    assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera", str(tmp_path)]) == 2
    assert "is a directory" in _one_error_line(capfd, f"camera file '{tmp_path}'")
    assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera", str(tmp_path / "no.json")]) == 2
    _one_error_line(capfd, f"camera file '{tmp_path / 'no.json'}': no such camera file")


BAD_MODELS = {  # one field of the snapshot's camera.json changed: the message names it
    "reflected rotation": ({"T_world_camera": [[-1, 0, 0, 0], [0, -1, 0, 0.45], [0, 0, -1, 0.48],
                                               [0, 0, 0, 1]]}, "'T_world_camera' rotation"),
    "K 1..9": ({"K": [[1, 2, 3], [4, 5, 6], [7, 8, 9]]}, "'K[2]' (bottom row)"),
    "fractional width": ({"width": 640.5}, "'width'"),
    "zero focal length": ({"K": [[0, 0, 319.5], [0, 659.4, 239.5], [0, 0, 1]]}, "'K[0][0]' (fx)"),
    # finite but out of range: a traceback (ZeroDivisionError, NaN to int) or a numpy warning before
    "huge focal length": ({"K": [[1e300, 0, 319.5], [0, 659.4, 239.5], [0, 0, 1]]},
                          "'K[0][0]' (fx) must be 0.64 to 640000 (pixels"),
    "tiny focal length": ({"K": [[1e-300, 0, 319.5], [0, 659.4, 239.5], [0, 0, 1]]},
                          "'K[0][0]' (fx) must be 0.64 to 640000"),
    "huge principal point": ({"K": [[659.4, 0, 1e300], [0, 659.4, 239.5], [0, 0, 1]]},
                             "'K[0][2]' (cx) must be -640 to 1280 (pixels"),
    "huge distortion": ({"dist": [0, 0, -1e300, 0, 0]}, "'dist[2]' must be -100 to 100"),
    "far camera": ({"T_world_camera": [[1, 0, 0, 1e300], [0, -1, 0, 0.45], [0, 0, -1, 0.48],
                                       [0, 0, 0, 1]]}, "'T_world_camera[0][3]' must be -100 to 100 (metres"),
}


@pytest.mark.parametrize(("change", "field"), BAD_MODELS.values(), ids=BAD_MODELS.keys())
def test_invalid_camera_models_exit_2_naming_the_field(change, field, snapshot, tmp_path, capfd):
    cam = _camera_variant(snapshot, tmp_path, **change)
    assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera", cam]) == 2
    _one_error_line(capfd, cam, field)


_DOWN = [[1, 0, 0, 0], [0, -1, 0, 0.45], [0, 0, -1, 0.48], [0, 0, 0, 1]]  # the overhead camera's pose
EDGE_CAMERAS = {  # valid models at the ends of the ranges: each runs, or is one error line
    "widest lens": {"K": [[0.64, 0, 319.5], [0, 0.64, 239.5], [0, 0, 1]]},
    "narrowest lens": {"K": [[640000, 0, 319.5], [0, 640000, 239.5], [0, 0, 1]]},
    "strongest distortion": {"dist": [100, 100, 100, 100, 100]},
    "strongest negative distortion": {"dist": [-100, -100, -100, -100, -100]},
    "distortion folding the principal point": {"K": [[5, 0, 0], [0, 0.65, -480], [0, 0, 1]],
                                               "dist": [0, 0, 0, -100, 0]},  # a NaN to int before
    "farthest camera": {"T_world_camera": [[1, 0, 0, 100], [0, -1, 0, -100], [0, 0, -1, 100], [0, 0, 0, 1]]},
    "camera looking along the plane": {"T_world_camera": [[1, 0, 0, 0], [0, 0, 1, 0.45],
                                                          [0, -1, 0, 0.48], [0, 0, 0, 1]]},
    "camera below the plane": {"T_world_camera": [*_DOWN[:2], [0, 0, -1, -100], _DOWN[3]]},
}


@pytest.mark.filterwarnings("error::RuntimeWarning")  # a numpy warning would reach stderr
@pytest.mark.parametrize("change", EDGE_CAMERAS.values(), ids=EDGE_CAMERAS.keys())
def test_cameras_at_the_ends_of_the_ranges_give_output_or_one_error_line(change, snapshot, tmp_path,
                                                                          capfd):
    cam = _camera_variant(snapshot, tmp_path, **change)
    code = cell_main(["detect", str(snapshot / "rgb.png"), "--camera", cam, "--json"])
    if code == 2:
        assert "camera model: " in _one_error_line(capfd)
    else:
        out, err = capfd.readouterr()
        assert code == 0 and err == "", err
        json.loads(out, parse_constant=_no_constants)


@pytest.mark.parametrize("extra", [["--\x1b[31mx"], ["extra\x1b]0;title\x07"], ["--json", "--\x1b[2J"]])
def test_option_errors_are_printed_escaped(extra, snapshot, capfd):
    with pytest.raises(SystemExit) as exit_:
        cell_main(["detect", str(snapshot / "rgb.png"), "--camera", str(snapshot / "camera.json"), *extra])
    out, err = capfd.readouterr()
    assert exit_.value.code == 2 and out == "" and err.startswith("usage: cell detect")
    errors = [ln for ln in err.splitlines() if "error:" in ln]
    assert len(errors) == 1 and "\x1b" not in err and "\x07" not in err, err
    assert "unrecognized arguments: " + extra[-1].encode("unicode_escape").decode() in errors[0]


@pytest.mark.parametrize("assignment", ["parts.count=5", "camera.width=64", "seed=3", "bogus=1",
                                        "\x1b[31m.x=1"])
def test_set_takes_vision_settings_only(assignment, snapshot, capfd):
    code = cell_main(["detect", str(snapshot / "rgb.png"), "--camera", str(snapshot / "camera.json"),
                      "--set", assignment])
    assert code == 2
    key = assignment.partition("=")[0].encode("unicode_escape").decode()
    line = _one_error_line(capfd, f"key '{key}' is not a vision setting", "[vision] section",
                           "segmentation, shadow_chroma")
    assert "\x1b" not in line


def test_set_without_equals_gives_a_vision_example(snapshot, capfd):
    assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera", str(snapshot / "camera.json"),
                      "--set", "segmentation"]) == 2
    _one_error_line(capfd, "--set segmentation: expected KEY=VALUE, e.g. --set segmentation=otsu")


def _refuse_decoding(*args, **kwargs):
    raise AssertionError("the image was decoded")


def test_a_size_bomb_is_refused_from_its_header(snapshot, tmp_path, capfd, monkeypatch):
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_header(25_000, 25_000))
    monkeypatch.setattr(cv2, "imread", _refuse_decoding)
    cam = str(snapshot / "camera.json")
    assert cell_main(["detect", str(bomb), "--camera", cam]) == 2
    _one_error_line(capfd, f"'{bomb}'", "25000x25000", "640x480")
    big_camera = _camera_variant(snapshot, tmp_path, width=25_000, height=25_000)
    assert cell_main(["detect", str(bomb), "--camera", big_camera]) == 2
    _one_error_line(capfd, f"'{bomb}'", "25000x25000", f"{MAX_PIXELS:,}")


def test_an_image_of_another_size_is_refused_before_decoding(snapshot, tmp_path, capfd, monkeypatch):
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((48, 64, 3), np.uint8))
    monkeypatch.setattr(cv2, "imread", _refuse_decoding)
    assert cell_main(["detect", str(small), "--camera", str(snapshot / "camera.json")]) == 2
    _one_error_line(capfd, f"'{small}'", "64x48", "640x480")


def _bad_image(kind: str, snapshot, tmp_path) -> tuple[str, str]:
    """(path, expected words) of an image file that is missing, a directory, text or cut short."""
    path = tmp_path / "image.png"
    if kind == "missing":
        return str(path), f"no such image file: '{path}'"
    if kind == "directory":
        path.mkdir()
        return str(path), "is a directory"
    if kind == "text":
        path.write_text("not an image\n")
        return str(path), "is not an image"
    png = (snapshot / "rgb.png").read_bytes()
    path.write_bytes(png[: len(png) // 2])  # cut in its pixel data: OpenCV logs a libpng error
    return str(path), "cannot decode"


@pytest.mark.parametrize("kind", ["missing", "directory", "text", "truncated"])
def test_bad_image_files_are_one_line_without_opencv_logging(kind, snapshot, tmp_path, capfd):
    path, words = _bad_image(kind, snapshot, tmp_path)
    assert cell_main(["detect", path, "--camera", str(snapshot / "camera.json")]) == 2
    assert "[ WARN" not in _one_error_line(capfd, f"'{path}'", words)  # libpng's own line: none either


def test_paths_are_printed_escaped(snapshot, tmp_path, capfd):
    path = tmp_path / "a\x1b[2J\x1b]0;title\x07.png"
    assert cell_main(["detect", str(path), "--camera", str(snapshot / "camera.json")]) == 2
    line = _one_error_line(capfd, r"a\x1b[2J\x1b]0;title\x07.png")
    assert "\x1b" not in line and "\x07" not in line
    cam = tmp_path / "c\x1b[31m.json"
    assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera", str(cam)]) == 2
    assert "\x1b" not in _one_error_line(capfd, r"c\x1b[31m.json")
    path.write_bytes((snapshot / "rgb.png").read_bytes())  # the table's first line names the image
    assert cell_main(["detect", str(path), "--camera", str(snapshot / "camera.json")]) == 0
    out = capfd.readouterr().out
    assert "\x1b" not in out and r"a\x1b[2J\x1b]0;title\x07.png" in out.splitlines()[0]


def test_an_image_path_that_is_not_utf8_is_read(snapshot, tmp_path):
    # (a subprocess: before, cv2.imread crashed the process on such a path)
    path = os.path.join(os.fsencode(tmp_path), b"caf\xe9.png")
    with open(path, "wb") as f:
        f.write((snapshot / "rgb.png").read_bytes())
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    r = subprocess.run([sys.executable, "-m", "cell.cli", "detect", path, "--camera",
                        str(snapshot / "camera.json"), "--json"], capture_output=True, env=env,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert len(json.loads(r.stdout)["detections"]) == 2


def _no_constants(name: str):
    raise AssertionError(f"non-finite constant {name} in the JSON output")


def test_json_output_is_strict_json(snapshot, capsys):
    assert main([str(snapshot / "rgb.png"), "--camera", str(snapshot / "camera.json"), "--json"]) == 0
    json.loads(capsys.readouterr().out, parse_constant=_no_constants)


def test_nan_never_reaches_the_output(snapshot, capfd):
    args = ["detect", str(snapshot / "rgb.png"), "--camera", str(snapshot / "camera.json"),
            "--set", "albedo_sigma=nan"]  # refused by the settings or by the output check
    for extra in (["--json"], []):
        assert cell_main(args + extra) == 2
        _one_error_line(capfd)


def test_a_non_finite_detection_is_an_error_not_output(snapshot, capfd, monkeypatch):
    real = PartDetector.detect

    def detect_nan_yaw(self, image, camera):
        return [dataclasses.replace(d, yaw=math.nan) for d in real(self, image, camera)]

    monkeypatch.setattr(PartDetector, "detect", detect_nan_yaw)
    for extra in (["--json"], []):
        assert cell_main(["detect", str(snapshot / "rgb.png"), "--camera",
                          str(snapshot / "camera.json"), *extra]) == 2
        _one_error_line(capfd, "detection 1: 'yaw' is nan, not a finite number")


def test_a_grey_image_is_refused_naming_why(snapshot, tmp_path, capfd):
    # (a grey frame gave 0 detections: every part colourless, hence a shadow)
    grey = tmp_path / "grey.png"
    rgb = cv2.imread(str(snapshot / "rgb.png"))
    cv2.imwrite(str(grey), cv2.cvtColor(rgb, cv2.COLOR_BGR2GRAY))
    assert cell_main(["detect", str(grey), "--camera", str(snapshot / "camera.json")]) == 2
    _one_error_line(capfd, f"'{grey}'", "grey image", "needs colour")


def test_a_jpeg_exif_orientation_is_not_applied(snapshot, tmp_path, capsys):
    # (the decoder turned the pixels by the EXIF tag: a 180-degree tag mirrored every
    # position; the camera model describes the pixels as the camera took them)
    from PIL import Image

    path = tmp_path / "turned.jpg"
    with Image.open(snapshot / "rgb.png") as im:
        exif = Image.Exif()
        exif[0x0112] = 3  # orientation: rotated 180 degrees
        im.convert("RGB").save(path, quality=98, subsampling=0, exif=exif.tobytes())
    args = ["--camera", str(snapshot / "camera.json"), "--json"]
    assert main([str(path), *args]) == 0
    xs = sorted(d["position"][0] for d in json.loads(capsys.readouterr().out)["detections"])
    truth = json.loads((snapshot / "truth.json").read_text())
    assert xs == pytest.approx(truth, abs=1e-3)


@pytest.mark.parametrize(("quality", "subsampling", "why", "form"), [
    (90, 2, "4:2:0 chroma, quantisation steps up to", "JPEG"),
    (100, 2, "4:2:0 chroma)", "JPEG"),
    (90, 0, "(quantisation steps up to", "JPEG"),
    (90, 2, "4:2:0 chroma, quantisation steps up to", "MPO"),  # (a phone's JPEG pair)
])
def test_a_lossy_jpeg_is_detected_with_a_warning(snapshot, tmp_path, capsys, quality,
                                                 subsampling, why, form):
    # (its artefacts cost parts and materials: the compression study; the user is told)
    from PIL import Image

    path = tmp_path / "frame.jpg"
    with Image.open(snapshot / "rgb.png") as im:
        rgb = im.convert("RGB")
        rgb.save(path, format=form, quality=quality, subsampling=subsampling,
                 **({"save_all": True, "append_images": [rgb]} if form == "MPO" else {}))
    assert main([str(path), "--camera", str(snapshot / "camera.json"), "--json"]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("cell detect: warning: image file ")
    assert f"'{path}' is a lossy JPEG" in lines[0] and why in lines[0]
    assert out["warnings"] == [lines[0].removeprefix("cell detect: warning: ")]
    assert len(out["detections"]) == 2


def test_a_png_or_a_fine_jpeg_gives_no_warning(snapshot, tmp_path, capsys):
    from PIL import Image

    fine = tmp_path / "fine.jpg"
    with Image.open(snapshot / "rgb.png") as im:
        im.convert("RGB").save(fine, quality=98, subsampling=0)
    for path in (snapshot / "rgb.png", fine):
        assert main([str(path), "--camera", str(snapshot / "camera.json"), "--json"]) == 0
        captured = capsys.readouterr()
        assert captured.err == "" and json.loads(captured.out)["warnings"] == []
