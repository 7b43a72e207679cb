"""Lighting presets change the image, each in the way its name promises."""

from __future__ import annotations

import numpy as np
import pytest

from cell.catalogue import LIGHTING_PRESETS
from cell.errors import SimError


@pytest.fixture(scope="module")
def renders(module_world_factory):
    world = module_world_factory(parts={"count": 4, "kinds": ["disc", "hex_nut"],
                              "materials": ["steel", "plastic_red"]})
    for i, (x, y) in enumerate([(-0.06, 0.43), (-0.02, 0.47), (0.03, 0.43), (0.07, 0.47)]):
        world.place_next_part(x, y, 0.4 * i)
    world.step(100)
    out = {}
    for name in LIGHTING_PRESETS:
        world.set_lighting(name)
        out[name] = world.render()
    return out


def test_every_preset_changes_the_image(renders):
    names = list(renders)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            diff = np.abs(renders[a].rgb.astype(int) - renders[b].rgb.astype(int)).mean()
            assert diff > 2.0, (a, b, diff)


def test_back_light_makes_silhouettes(renders):
    frame = renders["back"]
    grey = frame.rgb.mean(axis=2)
    parts = frame.seg > 0
    near = np.zeros_like(parts)
    for pid in np.unique(frame.seg[parts]):
        v, u = np.nonzero(frame.seg == pid)
        near[max(v.min() - 8, 0): v.max() + 9, max(u.min() - 8, 0): u.max() + 9] = True
    background = near & ~parts
    assert grey[background].mean() > 200
    assert grey[parts].mean() < grey[background].mean() - 100


def test_dim_is_darker_and_noisier_than_front(renders):
    front, dim = renders["front"].rgb.astype(float), renders["dim"].rgb.astype(float)
    assert dim.mean() < 0.6 * front.mean()

    def noise(img):  # residual after a 3x3 box filter, on the flat belt
        import cv2

        patch = img[125:170, 100:540].mean(axis=2)  # belt only, no part
        return np.std(patch - cv2.blur(patch, (3, 3)))

    assert noise(dim) > 2 * noise(front)


def test_unknown_preset_is_an_error_listing_the_valid_ones(world_factory):
    world = world_factory(parts={"count": 1})
    with pytest.raises(SimError, match="valid: front, back"):
        world.set_lighting("disco")
