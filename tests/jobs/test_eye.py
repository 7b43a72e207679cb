"""The sort job's eye: black frames, the back + front merge, the second look (with fakes)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cell.jobs.eye import Eye, is_black, merge_materials
from cell.scenario import scenario_from_dict
from cell.vision.detector import Detection


def _det(x: float, y: float, material: str = "metal", confidence: float = 0.9) -> Detection:
    return Detection(id=1, material=material, material_confidence=confidence, kind="washer",
                     kind_confidence=1.0, centroid=(0.0, 0.0), yaw=0.0, symmetry=0,
                     position=(x, y), size=(0.02, 0.02), partial=False)


class _Frame:
    def __init__(self, rgb: np.ndarray) -> None:
        self.rgb, self.seg = rgb, None


class _World:
    """Renders a grey frame, or a black one under ``dark``; records the lighting."""

    def __init__(self, dark: str = "") -> None:
        self.lighting_name, self.dark, self.lit = "front", dark, []

    def set_lighting(self, name: str) -> None:
        self.lighting_name = name
        self.lit.append(name)

    def render(self, camera: str, *, depth: bool, seg: bool) -> _Frame:
        level = 0 if self.lighting_name == self.dark else 120
        return _Frame(np.full((48, 64, 3), level, np.uint8))


class _Detector:
    """Sees one part at (0, 0.45): plastic at 0.99 under any light."""

    def detect(self, image: np.ndarray, camera: object) -> list:
        return [_det(0.0, 0.45, "plastic", 0.99)]


def test_black_frames_are_told_from_dark_ones():
    assert is_black(np.zeros((48, 64, 3), np.uint8))
    noisy_black = np.random.default_rng(0).integers(0, 4, (48, 64, 3)).astype(np.uint8)
    assert is_black(noisy_black)
    dark_scene = np.full((48, 64, 3), 20, np.uint8)
    assert not is_black(dark_scene)


def test_merge_takes_the_nearest_material_within_6_mm():
    outline = [_det(0.0, 0.45, "unknown", 0.0), _det(0.05, 0.45, "unknown", 0.0)]
    material = [_det(0.004, 0.45, "plastic", 0.97), _det(0.2, 0.45, "metal", 0.99)]
    merged = merge_materials(outline, material)
    assert (merged[0].material, merged[0].material_confidence) == ("plastic", 0.97)
    assert (merged[1].material, merged[1].material_confidence) == ("unknown", 0.0)
    assert merged[0].position == outline[0].position  # the outline's geometry is kept


def test_second_opinion_looks_under_the_preset_and_restores_the_light():
    scenario = scenario_from_dict({})
    world = _World()
    eye = Eye(world, camera=None, detector=_Detector(), scenario=scenario)
    unsure = _det(0.001, 0.45, "metal", 0.53)
    other = eye.second_opinion(unsure, "coaxial")
    assert world.lit == ["coaxial", "front"] and world.lighting_name == "front"
    assert other == dataclasses.replace(unsure, material="plastic", material_confidence=0.99)


def test_second_opinion_of_a_black_frame_is_none():
    scenario = scenario_from_dict({})
    eye = Eye(_World(dark="coaxial"), camera=None, detector=_Detector(), scenario=scenario)
    assert eye.second_opinion(_det(0.0, 0.45), "coaxial") is None


class _LitWorld(_World):
    """Grey level 200 under ``back``, 100 otherwise; black for the first ``black`` renders;
    counts the physics steps taken between retakes."""

    def __init__(self, black: int = 0) -> None:
        super().__init__()
        self.black, self.steps, self.time = black, 0, 0.0
        self.model = type("M", (), {"opt": type("O", (), {"timestep": 0.002})()})()

    def step(self, n: int) -> None:
        self.steps += n
        self.time += n * 0.002

    def render(self, camera: str, *, depth: bool, seg: bool) -> _Frame:
        if self.black > 0:
            self.black -= 1
            return _Frame(np.zeros((48, 64, 3), np.uint8))
        return _Frame(np.full((48, 64, 3), 200 if self.lighting_name == "back" else 100, np.uint8))


class _SilhouetteDetector:
    """Under the back light: the outline at (0, 0.45), material unknown; under the front
    light: the same part seen 3 mm off, plastic."""

    def detect(self, image: np.ndarray, camera: object) -> list:
        if image.mean() > 150:
            return [_det(0.0, 0.45, "unknown", 0.0)]
        return [_det(0.003, 0.45, "plastic", 0.97)]


def test_a_back_and_front_look_takes_the_outline_from_back_and_the_material_from_front():
    scenario = scenario_from_dict({"capture": {"presets": ["back", "front"]}})
    capture = Eye(_LitWorld(), camera=None, detector=_SilhouetteDetector(), scenario=scenario).look()
    (d,) = capture.detections
    assert list(capture.images) == ["back", "front"]
    assert d.position == (0.0, 0.45) and (d.material, d.material_confidence) == ("plastic", 0.97)


def test_a_black_frame_is_retaken_sort_retakes_times():
    scenario = scenario_from_dict({"sort": {"retakes": 2, "retake_wait": 0.1}})
    world = _LitWorld(black=2)  # two black frames, then a picture: the second retake sees it
    capture = Eye(world, camera=None, detector=_SilhouetteDetector(), scenario=scenario).look()
    assert capture is not None and capture.retakes == 2 and world.steps == 2 * 50
    assert capture.t == pytest.approx(0.2)
    world = _LitWorld(black=3)  # three: every retake black
    assert Eye(world, camera=None, detector=_SilhouetteDetector(), scenario=scenario).look() is None
    assert world.steps == 2 * 50
