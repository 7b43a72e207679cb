"""Lighting presets, switched at run time without recompiling the model.

The world holds every light a preset may need (``add_lights``); a preset
(``apply_lighting``) only turns lights on and off, sets their colours and shadows, the
headlight, and the belt's emission (the ``back`` light table). Only ``raking`` casts
shadows: it is the preset that is about shadows, and shadow maps cost most of a frame.
``LightingPreset.gain`` is the sensor gain the camera needs under that light: it
multiplies the sensor's read noise (``dim`` is noisy because it is dark).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from cell.catalogue import LIGHTING_PRESETS
from cell.errors import SimError
from cell.sim import layout
from cell.sim.conveyor import BELT_RGBA
from cell.text import show

__all__ = ["LIGHTS", "PRESETS", "LightingPreset", "add_lights", "apply_lighting"]

_P = layout.PICK_ZONE
# name -> (position, direction, spot cutoff deg (0 = directional), shadow-casting)
LIGHTS: dict[str, tuple[list[float], list[float], float, bool]] = {
    "key": ([_P[0] - 0.25, _P[1] - 0.35, 0.9], [0.25, 0.35, -0.82], 0.0, False),
    "fill": ([_P[0] + 0.3, _P[1] + 0.3, 0.9], [-0.3, -0.3, -0.82], 0.0, False),
    # from the far side of the belt, so the arm never stands between it and the parts
    "raking": ([_P[0], _P[1] + 0.5, _P[2] + 0.2], [0.0, -1.0, -0.4], 25.0, True),
    "coaxial": ([_P[0], _P[1], _P[2] + 0.38], [0.0, 0.0, -1.0], 50.0, False),
    "glare": ([_P[0] + 0.06, _P[1], _P[2] + 0.45], [-0.13, 0.0, -1.0], 35.0, False),
}


@dataclass(frozen=True)
class LightingPreset:
    """Which lights are on, with which diffuse colour (0..1 RGB), plus headlight and gain.

    ``lights`` maps a light name of ``LIGHTS`` to (diffuse rgb, specular rgb).
    ``ambient`` is the headlight's ambient term; ``belt_emission`` lights the belt up.
    """

    lights: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]]
    ambient: float
    belt_emission: float = 0.0
    gain: float = 1.0


_WHITE, _SPEC = (0.55, 0.55, 0.55), (0.3, 0.3, 0.3)
PRESETS: dict[str, LightingPreset] = {
    "front": LightingPreset({"key": (_WHITE, _SPEC), "fill": ((0.3, 0.3, 0.3), (0.1,) * 3)}, 0.25),
    "back": LightingPreset({}, 0.06, belt_emission=1.0),
    "raking": LightingPreset({"raking": ((1.0, 1.0, 1.0), _SPEC)}, 0.22),
    "coaxial": LightingPreset({"coaxial": ((0.75, 0.75, 0.75), (0.5, 0.5, 0.5))}, 0.2),
    "dim": LightingPreset({"key": ((0.16, 0.16, 0.16), (0.06,) * 3)}, 0.07, gain=4.0),
    "glare": LightingPreset(
        {"glare": ((0.5, 0.5, 0.5), (1.0, 1.0, 1.0)), "fill": ((0.2, 0.2, 0.2), (0.0,) * 3)}, 0.2
    ),
    "warm": LightingPreset(
        {"key": ((0.65, 0.5, 0.32), _SPEC), "fill": ((0.35, 0.27, 0.17), (0.1,) * 3)}, 0.22
    ),
    "cool": LightingPreset(
        {"key": ((0.45, 0.52, 0.65), _SPEC), "fill": ((0.24, 0.28, 0.35), (0.1,) * 3)}, 0.22
    ),
}
assert set(PRESETS) == set(LIGHTING_PRESETS), "every catalogue preset needs a definition"


def add_lights(spec: mujoco.MjSpec) -> None:
    """Add every light of ``LIGHTS`` (all off until a preset turns them on)."""
    for name, (pos, direction, cutoff, shadow) in LIGHTS.items():
        light = spec.worldbody.add_light(name=name, pos=pos, dir=direction)
        light.castshadow = shadow
        light.active = False
        if cutoff > 0:
            light.type = mujoco.mjtLightType.mjLIGHT_SPOT
            light.cutoff = cutoff
            light.exponent = 1.0
        else:
            light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    spec.visual.headlight.diffuse = [0.0, 0.0, 0.0]
    spec.visual.headlight.specular = [0.0, 0.0, 0.0]
    # The raking spot's cone just covers the overhead view. On a CPU renderer the shadow
    # pass costs in proportion to the map's pixels: 512 keeps a raking frame under 25 ms;
    # 768 looked smoother but measured the same detector accuracy (README: rendering).
    spec.visual.quality.shadowsize = 512


def apply_lighting(model: mujoco.MjModel, name: str) -> LightingPreset:
    """Switch ``model`` to preset ``name``; effective on the next render. Returns it."""
    if name not in PRESETS:
        raise SimError(f"unknown lighting preset {show(name)}; valid: {', '.join(PRESETS)}")
    preset = PRESETS[name]
    for light in LIGHTS:
        lid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_LIGHT, light)
        on = light in preset.lights
        model.light_active[lid] = on
        if on:
            diffuse, specular = preset.lights[light]
            model.light_diffuse[lid] = diffuse
            model.light_specular[lid] = specular
    model.vis.headlight.ambient = np.full(3, preset.ambient)
    belt = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "belt")
    model.mat_emission[belt] = preset.belt_emission
    model.mat_rgba[belt] = (0.92, 0.93, 0.95, 1) if preset.belt_emission > 0 else BELT_RGBA
    return preset
