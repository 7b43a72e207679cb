"""The sort job's scenario sections: ``[capture]``, ``[sort]`` and ``[faults]``.

Plain data (no MuJoCo, no OpenCV), so loading a scenario stays cheap. Units in each
field's doc; every field has a default, so a scenario without these sections is the
fault-free job under its ``lighting`` preset.

Example::

    [capture]
    presets = ["back", "front"]   # outline from the back light, material from the front

    [faults]
    blackout = [12.0, 1.5]        # the camera delivers black frames from 12 s for 1.5 s
    suction_fail = [2]            # the vacuum of the 2nd grasp fails
    flipped = [3]                 # part 3 arrives flipped (a bolt on its head)
"""

from __future__ import annotations

from dataclasses import dataclass

from cell.catalogue import LIGHTING_PRESETS
from cell.config import check, setting
from cell.errors import ScenarioError

__all__ = ["CaptureSettings", "FaultSettings", "SortSettings"]


@dataclass(frozen=True)
class CaptureSettings:
    """What the overhead camera takes of each part."""

    presets: tuple[str, ...] = setting(
        (), choices=tuple(LIGHTING_PRESETS),
        doc="lighting presets of the captures, in order (empty: the scenario's 'lighting'); "
        "with two, the outline and position come from the first, the material from the second",
    )

    def __post_init__(self) -> None:
        check(self, "capture")  # every field, however the object was made

    def _validate(self, where: str) -> None:
        if len(self.presets) > 2:
            raise ScenarioError(f"{where}: key 'capture.presets' takes at most 2 presets "
                                f"(outline, then material), got {len(self.presets)}")


@dataclass(frozen=True)
class SortSettings:
    """How the sort job decides, and how long it waits."""

    min_kind_confidence: float = setting(
        0.6, lo=0.0, hi=1.0, doc="a part whose kind confidence is lower goes to the reject bin")
    min_material_confidence: float = setting(
        0.6, lo=0.0, hi=1.0, doc="a part whose material confidence is lower goes to the reject bin")
    attempts: int = setting(
        3, lo=1, hi=10, doc="pick attempts at one part (each from a fresh image) before it is let go")
    relooks: int = setting(
        2, lo=0, hi=10,
        doc="index mode: further looks when a part blocks the barrier but none is found, or "
        "the part to pick would be rejected as unsure (each image has its own sensor noise)")
    second_preset: str = setting(
        "coaxial", choices=("", *LIGHTING_PRESETS),
        doc="index mode: when only its material keeps a part from its bin (still unsure after "
        "the relooks), one more look under this preset decides it if that look is sure "
        "('' = none; skipped when the captures already use it)")
    retakes: int = setting(
        20, lo=1, hi=1000, doc="captures retaken while the camera delivers unusable frames")
    retake_wait: float = setting(
        0.25, lo=0.01, hi=10.0, doc="wait before a capture is retaken (s)")
    arrival_timeout: float = setting(
        30.0, lo=1.0, hi=600.0,
        doc="the job ends when the belt's encoder does not move for this long (s): a stopped "
        "belt, or a part let go that never leaves the barrier (index mode)")
    pick_window: tuple[float, ...] = setting(
        (-0.12, 0.12), lo=-0.3, hi=0.3, length=2,
        doc="the stretch of belt the arm picks from, along x from the pick zone (m)")

    def __post_init__(self) -> None:
        check(self, "sort")  # every field, however the object was made

    def _validate(self, where: str) -> None:
        lo, hi = self.pick_window
        if lo >= hi:
            raise ScenarioError(f"{where}: key 'sort.pick_window' must be [low, high] with "
                                f"low < high (m), got [{lo:g}, {hi:g}]")


@dataclass(frozen=True)
class FaultSettings:
    """Faults injected into the simulated cell (the job sees only their effects)."""

    blackout: tuple[float, ...] = setting(
        (), lo=0.0, hi=3600.0, doc="[start, duration] (s): the camera delivers black frames")
    conveyor_stop: tuple[float, ...] = setting(
        (), lo=0.0, hi=3600.0, doc="[start, duration] (s): the belt stands still")
    suction_fail: tuple[int, ...] = setting(
        (), lo=1, hi=10_000, doc="grasp numbers (1-based) whose vacuum never seals")
    drop: tuple[int, ...] = setting(
        (), lo=1, hi=10_000, doc="grasp numbers (1-based) whose part falls off the cup in transfer")
    flipped: tuple[int, ...] = setting(
        (), lo=1, hi=200,
        doc="part numbers (1-based) spawned flipped: a bolt on its head, a bracket on its edge, "
        "others upside down")
    touching: tuple[int, ...] = setting(
        (), lo=2, hi=200, doc="part numbers (from 2) spawned touching the part before them")

    def __post_init__(self) -> None:
        check(self, "faults")  # every field, however the object was made

    def _validate(self, where: str) -> None:
        for key in ("blackout", "conveyor_stop"):
            if len(getattr(self, key)) not in (0, 2):
                raise ScenarioError(f"{where}: key 'faults.{key}' must be [start, duration] "
                                    f"in seconds, or empty")
        chained = sorted(k for k in self.touching if k - 1 in self.touching)
        if chained:  # (a pair is dropped together; a third part came 30 mm from the second)
            k = chained[0]
            raise ScenarioError(f"{where}: key 'faults.touching' lists {k - 1} and {k}: part {k} "
                                f"would touch part {k - 1}, itself touching part {k - 2}; only "
                                "pairs are made, so no two numbers may follow each other")

    @property
    def any(self) -> bool:
        """Whether any fault is set."""
        return any(getattr(self, f) for f in ("blackout", "conveyor_stop", "suction_fail",
                                               "drop", "flipped", "touching"))
