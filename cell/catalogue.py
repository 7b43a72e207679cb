"""What the cell knows by name: part kinds, materials and lighting presets.

Pure data, no MuJoCo: the scenario validator, the simulator, the vision stack and the
reports all read the same tables. Sizes are real-world sizes in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "KINDS",
    "LIGHTING_PRESETS",
    "MATERIALS",
    "PartKind",
    "PartMaterial",
]


@dataclass(frozen=True)
class PartKind:
    """A kind of part and its nominal geometry.

    ``length`` and ``width`` are the footprint of the part lying in its stable pose
    (metres, ``length >= width``), ``height`` its thickness on the belt (metres).
    ``hole`` is the diameter of a through hole seen from above (0 if none).
    ``symmetry`` is the order of its rotational symmetry about the vertical axis as
    seen from above: 0 means continuous (a washer), 6 a hex nut, 2 a bolt.
    """

    name: str
    length: float
    width: float
    height: float
    hole: float
    symmetry: int
    description: str

    @property
    def half_diagonal(self) -> float:
        """Half the diagonal of the ``length`` x ``width`` box (metres): how far apart two
        parts' centres keep them clear of each other, with the other's."""
        return 0.5 * math.hypot(self.length, self.width)

    def yaw_error(self, yaw: float, true_yaw: float) -> float | None:
        """The angle (radians, 0 to pi/symmetry) between two yaws of this kind, modulo its
        rotational symmetry (a hex nut turned by 60 degrees is the same nut); None for a
        round part (``symmetry`` 0), whose yaw means nothing."""
        if self.symmetry <= 0:
            return None
        period = 2 * math.pi / self.symmetry
        e = (yaw - true_yaw) % period
        return min(e, period - e)


@dataclass(frozen=True)
class PartMaterial:
    """A material finish: its class (``metal`` or ``plastic``), colour and optics.

    ``rgba`` is the base colour (0..1), ``specular`` and ``shininess`` are MuJoCo
    material parameters (0..1): metals are specular and unsaturated (brass is the
    coloured metal); plastics are matte.
    """

    name: str
    material: str
    colour: str
    rgba: tuple[float, float, float, float]
    specular: float
    shininess: float


KINDS: dict[str, PartKind] = {
    k.name: k
    for k in (
        PartKind("washer", 0.020, 0.020, 0.002, 0.0105, 0, "M10 flat washer (DIN 125)"),
        PartKind("hex_nut", 0.0196, 0.017, 0.008, 0.010, 6, "M10 hex nut, 17 mm across flats"),
        PartKind("square_nut", 0.013, 0.013, 0.0065, 0.008, 4, "M8 square nut (DIN 557)"),
        PartKind("bolt", 0.044, 0.0115, 0.010, 0.0, 2, "M6x40 hex bolt lying on its side"),
        PartKind("l_bracket", 0.040, 0.030, 0.003, 0.0, 1, "L bracket, 40x30 mm legs 12 mm wide"),
        PartKind("disc", 0.030, 0.030, 0.004, 0.0, 0, "30 mm cap / disc"),
    )
}

MATERIALS: dict[str, PartMaterial] = {
    m.name: m
    for m in (
        PartMaterial("steel", "metal", "steel", (0.60, 0.61, 0.63, 1), 0.9, 0.85),
        PartMaterial("aluminium", "metal", "aluminium", (0.78, 0.79, 0.80, 1), 0.9, 0.7),
        PartMaterial("brass", "metal", "brass", (0.78, 0.62, 0.30, 1), 0.9, 0.8),
        PartMaterial("plastic_red", "plastic", "red", (0.80, 0.08, 0.06, 1), 0.05, 0.1),
        PartMaterial("plastic_green", "plastic", "green", (0.10, 0.62, 0.15, 1), 0.05, 0.1),
        PartMaterial("plastic_blue", "plastic", "blue", (0.08, 0.22, 0.80, 1), 0.05, 0.1),
        PartMaterial("plastic_yellow", "plastic", "yellow", (0.92, 0.78, 0.06, 1), 0.05, 0.1),
        PartMaterial("plastic_white", "plastic", "white", (0.90, 0.90, 0.88, 1), 0.05, 0.1),
        PartMaterial("plastic_grey", "plastic", "grey", (0.45, 0.45, 0.46, 1), 0.05, 0.1),
        PartMaterial("plastic_black", "plastic", "black", (0.07, 0.07, 0.08, 1), 0.05, 0.1),
    )
}

LIGHTING_PRESETS: dict[str, str] = {
    "front": "diffuse light from above and in front, soft shadows",
    "back": "emissive light table under the pick zone: dark silhouettes on white",
    "raking": "one low-angle light from the side, long hard shadows",
    "coaxial": "light on the camera's optical axis: flat, shadow-free",
    "dim": "low light: the sensor's gain raises its noise",
    "glare": "one hard light placed for specular reflection into the camera",
    "warm": "front light at a warm colour temperature (about 3000 K)",
    "cool": "front light at a cool colour temperature (about 6500 K)",
}
