"""A user's detector (``vision.detector = "module:Class"``) cannot crash a job: what its
detect raises, or returns that is not a list of valid Detections, is a JobError naming it."""

from __future__ import annotations

import dataclasses
import sys
import types

import numpy as np
import pytest

from cell.errors import JobError
from cell.jobs.detectors import load_detector
from cell.vision.detector import Detection
from cell.vision.settings import VisionSettings

IMAGE = np.zeros((48, 64, 3), np.uint8)
GOOD = Detection(id=1, material="metal", material_confidence=0.9, kind="washer", kind_confidence=1.0,
                 centroid=(32.0, 24.0), yaw=0.0, symmetry=0, position=(0.0, 0.45), size=(0.02, 0.02),
                 partial=False)


def _returning(value):
    return type("Fake", (), {"detect": lambda self, image, camera: value})


class _Raises:
    def detect(self, image, camera):
        raise RuntimeError("boom \x1b[31mred\nline")


@pytest.fixture
def fake(monkeypatch):
    """Installs module ``fake_detectors`` holding the given classes; returns the loader."""
    module = types.ModuleType("fake_detectors")
    monkeypatch.setitem(sys.modules, "fake_detectors", module)

    def load(cls):
        module.Detector = cls
        return load_detector(VisionSettings(detector="fake_detectors:Detector"))

    return load


def test_an_exception_in_detect_is_one_escaped_line_naming_the_detector(fake):
    with pytest.raises(JobError) as info:
        fake(_Raises).detect(IMAGE, None)
    message = str(info.value)
    assert "'fake_detectors:Detector'" in message and "RuntimeError: boom" in message
    assert "\x1b" not in message and "\n" not in message


@pytest.mark.parametrize(("returned", "culprit"), [
    (None, "detect returned NoneType, not a list of Detection"),
    ([GOOD, 1], "detection 2 of 2 is int, not a Detection"),
    ([dataclasses.replace(GOOD, position=(float("nan"), 0.45))], "position"),
    ([dataclasses.replace(GOOD, yaw=float("inf"))], "yaw"),
    ([dataclasses.replace(GOOD, material="\x1b[31mmetal")], "material must be one of metal, plastic"),
    ([dataclasses.replace(GOOD, kind="screw")], "kind must be one of washer"),
    ([dataclasses.replace(GOOD, centroid=(1e300, 24.0))], "outside the 64x48 image"),
])
def test_what_detect_returns_is_checked(fake, returned, culprit):
    with pytest.raises(JobError, match="vision.detector 'fake_detectors:Detector'") as info:
        fake(_returning(returned)).detect(IMAGE, None)
    assert culprit in str(info.value) and "\x1b" not in str(info.value)


def test_valid_detections_come_back_with_plain_numbers(fake):
    numpy_typed = dataclasses.replace(GOOD, id=np.int64(1), material_confidence=np.float32(0.5),
                                      centroid=np.array([32.0, 24.0]), partial=np.bool_(False))
    (det,) = fake(_returning((numpy_typed,))).detect(IMAGE, None)
    assert det == dataclasses.replace(GOOD, material_confidence=0.5)
    assert type(det.id) is int and type(det.material_confidence) is float


class _Keywords:
    def __init__(self, *, level=7, **options):
        self.level, self.options = level, options

    def detect(self, image, camera):
        return []


class _Settings:
    def __init__(self, settings, extra=1):
        self.settings = settings

    def detect(self, image, camera):
        return []


def test_a_constructor_with_keyword_parameters_only_is_called_with_none(fake):
    built = fake(_Keywords).detector
    assert (built.level, built.options) == (7, {})


def test_a_constructor_with_a_positional_parameter_gets_the_settings(fake):
    assert isinstance(fake(_Settings).detector.settings, VisionSettings)


class _Tunable:
    def __init__(self, min_area=60):
        self.min_area = min_area

    def detect(self, image, camera):
        return []


class _OptionalSettings:
    def __init__(self, settings=None):
        self.settings = settings

    def detect(self, image, camera):
        return []


def test_an_optional_first_parameter_keeps_its_default_unless_named_settings(fake):
    # (min_area=60 was given the VisionSettings: any positional parameter took them)
    assert fake(_Tunable).detector.min_area == 60
    assert isinstance(fake(_OptionalSettings).detector.settings, VisionSettings)


@pytest.mark.parametrize(("returned", "culprit"), [
    # v past the height
    ([dataclasses.replace(GOOD, centroid=(32.0, 60.0))], "outside the 64x48 image"),
    ([dataclasses.replace(GOOD, centroid=(-0.5, 24.0))], "outside the 64x48 image"),
    ([dataclasses.replace(GOOD, material_confidence=1.5)],
     "material_confidence must be a finite number in 0..1"),
    ([dataclasses.replace(GOOD, kind_confidence=1.2)], "kind_confidence must be a finite number in 0..1"),
    ([dataclasses.replace(GOOD, kind_confidence=-0.1)], "kind_confidence must be a finite number in 0..1"),
    ([dataclasses.replace(GOOD, size=(-0.02, 0.02))], "size must be two finite numbers, each >= 0"),
    ([dataclasses.replace(GOOD, id=-1)], "id must be a whole number >= 0"),
    ([dataclasses.replace(GOOD, symmetry=-2)], "symmetry must be a whole number >= 0"),
])
def test_out_of_range_fields_of_a_detection_are_refused(fake, returned, culprit):
    with pytest.raises(JobError, match="vision.detector 'fake_detectors:Detector'") as info:
        fake(_returning(returned)).detect(IMAGE, None)
    assert culprit in str(info.value)
