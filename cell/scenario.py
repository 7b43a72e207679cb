"""Scenarios: one TOML file, validated into a frozen ``Scenario`` dataclass.

Every field has a default, so an empty file is a valid scenario. An unknown key, a wrong
type, an out-of-range or non-finite number or a string with control characters raises
``ScenarioError`` naming the key and the file; so does a file that cannot be read, is not
UTF-8 (a leading byte-order mark is accepted) or is larger than 1 MiB.
``--set key=value`` overrides (dotted keys for sections) are applied after the file.

Example::

    seed = 3
    lighting = "back"

    [parts]
    count = 5
    kinds = ["washer", "hex_nut"]

    [conveyor]
    speed = 0.1
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cell.calib.settings import CalibrationSettings
from cell.catalogue import KINDS, LIGHTING_PRESETS, MATERIALS
from cell.config import apply_override, build, check, setting
from cell.errors import CellError, ScenarioError
from cell.files import input_path, read_toml_file
from cell.jobs.settings import CaptureSettings, FaultSettings, SortSettings
from cell.robot.settings import RobotSettings
from cell.text import override_source, show
from cell.vision.settings import VisionSettings

__all__ = [
    "CameraSettings",
    "ConveyorSettings",
    "PartsSettings",
    "Scenario",
    "SensorSettings",
    "check_scenario",
    "load_scenario",
    "scenario_from_dict",
]



@dataclass(frozen=True)
class PartsSettings:
    count: int = setting(10, lo=1, hi=200, doc="parts spawned in a run (each is a body of the model)")
    kinds: tuple[str, ...] = setting(tuple(KINDS), choices=tuple(KINDS), doc="kinds to draw from")
    materials: tuple[str, ...] = setting(
        tuple(MATERIALS), choices=tuple(MATERIALS), doc="material finishes to draw from"
    )
    spacing: float = setting(
        0.10, lo=0.04, hi=2.0, doc="belt travel between two spawns (m)"
    )
    lateral_range: float = setting(
        0.04, lo=0.0, hi=0.06, doc="spawn offset across the belt, uniform in +-range (m)"
    )

    def __post_init__(self) -> None:
        check(self, "parts")  # every field, however the object was made

    def _validate(self, where: str) -> None:
        for key, value in (("parts.kinds", self.kinds), ("parts.materials", self.materials)):
            if not value:
                raise ScenarioError(f"{where}: key '{key}' must not be empty")


@dataclass(frozen=True)
class ConveyorSettings:
    speed: float = setting(0.10, lo=0.0, hi=0.5, doc="belt speed (m/s)")
    mode: str = setting(
        "index",
        choices=("index", "continuous"),
        doc="index: stop when a part breaks the light barrier; continuous: never stop",
    )

    def __post_init__(self) -> None:
        check(self, "conveyor")  # every field, however the object was made


@dataclass(frozen=True)
class CameraSettings:
    width: int = setting(640, lo=16, hi=4096, doc="image width (pixels)")
    height: int = setting(480, lo=16, hi=4096, doc="image height (pixels)")
    fovy: float = setting(40.0, lo=5.0, hi=120.0, doc="overhead camera vertical field of view (deg)")

    def __post_init__(self) -> None:
        check(self, "camera")  # every field, however the object was made


@dataclass(frozen=True)
class SensorSettings:
    noise_std: float = setting(1.5, lo=0.0, hi=100.0, doc="Gaussian read noise (grey levels)")
    salt_pepper: float = setting(0.0, lo=0.0, hi=0.5, doc="fraction of pixels set to 0 or 255")
    distortion: tuple[float, ...] = setting(
        (0.0, 0.0, 0.0, 0.0, 0.0), lo=-1.0, hi=1.0, length=5, doc="k1, k2, p1, p2, k3"
    )
    bits: int = setting(8, lo=1, hi=8, doc="bit depth per channel")

    def __post_init__(self) -> None:
        check(self, "sensor")  # every field, however the object was made


@dataclass(frozen=True)
class Scenario:
    name: str = setting("scenario", doc="a name for reports (printable characters only)")
    seed: int = setting(0, lo=0, hi=2**63 - 1, doc="seed of the run's random generator")
    lighting: str = setting("front", choices=tuple(LIGHTING_PRESETS), doc="lighting preset")
    parts: PartsSettings = setting(PartsSettings())
    conveyor: ConveyorSettings = setting(ConveyorSettings())
    camera: CameraSettings = setting(CameraSettings())
    sensor: SensorSettings = setting(SensorSettings())
    robot: RobotSettings = setting(RobotSettings())
    vision: VisionSettings = setting(VisionSettings())
    calibration: CalibrationSettings = setting(CalibrationSettings())
    capture: CaptureSettings = setting(CaptureSettings())
    sort: SortSettings = setting(SortSettings())
    faults: FaultSettings = setting(FaultSettings())

    def __post_init__(self) -> None:
        check(self)  # every field, however the object was made


def scenario_from_dict(
    data: dict[str, Any], *, where: str = "<dict>", overrides: tuple[str, ...] | list[str] = ()
) -> Scenario:
    """Validate a nested dict (and ``key=value`` overrides) into a ``Scenario``."""
    if isinstance(overrides, str | bytes):  # (it was read character by character)
        raise ScenarioError(f"overrides: expected a list of 'key=value' strings, got the "
                            f"string {show(overrides)}: put it in a list")
    scenario = build(Scenario, data, where=where)
    for assignment in overrides:  # validated one by one so an error names its --set
        data = apply_override(data, assignment, Scenario)
        scenario = build(Scenario, data, where=override_source(assignment))
    return scenario


def check_scenario(value: object, where: str, error: type[CellError]) -> Scenario:
    """``value`` when it is a :class:`Scenario`, else ``error`` naming ``where`` (the
    function it was given to) and how to make one."""
    if not isinstance(value, Scenario):
        raise error(f"{where}: argument 'scenario': expected a Scenario (cell.scenario."
                    f"load_scenario or scenario_from_dict), got {type(value).__name__}")
    return value


def load_scenario(
    path: str | Path, *, overrides: tuple[str, ...] | list[str] = (), seed: int | None = None
) -> Scenario:
    """Read a scenario TOML file, apply ``--set`` overrides and an optional seed.

    Raises ``ScenarioError`` naming the file (escaped) and key for any invalid input; an
    invalid ``seed`` is reported as ``--seed``.
    """
    path, shown = input_path(path, kind="scenario file", error=ScenarioError)
    data = read_toml_file(path, shown, kind="scenario file", error=ScenarioError)
    scenario = scenario_from_dict(data, where=shown, overrides=overrides)
    if seed is None:
        return scenario
    checked = build(Scenario, {"seed": seed}, where=f"--seed {show(seed)}")
    return dataclasses.replace(scenario, seed=checked.seed)
