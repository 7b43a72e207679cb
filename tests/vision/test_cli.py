"""`cell detect IMAGE --camera camera.json`: reads a snapshot's files, prints detections."""

from __future__ import annotations

import json

import cv2
import pytest

from cell.cli import main as cell_main
from cell.sim import layout
from cell.vision.cli import main


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
