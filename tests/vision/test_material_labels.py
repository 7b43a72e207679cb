"""The compiled grain features and material odds (cell.vision._material_labels) against
their Python formulation, bit for bit (Python's ``x ** 2`` is libm's ``pow``)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cell.vision._material_kernel import KEPT, MEAN, N_STATS, NORM, S_NOISE2, S_PAR, N
from cell.vision.material import _albedo_metal_probability, _grain, _labels


def _grain_py(stats, noise_sigma):
    floor = noise_sigma * math.sqrt((8 / 9) ** 2 + 8 / 81)
    out = []
    for row in stats.tolist():
        norm, s_par = row[NORM], row[S_PAR]
        s_noise = max(math.sqrt(max(row[S_NOISE2], 0.0)) / 1.1774, floor)
        grain_var = s_par**2 - s_noise**2
        se = math.sqrt(2.0 / (0.37 * max(row[KEPT], 1.0))) * (s_par**2 + s_noise**2) + 1e-9
        out.append((math.sqrt(max(grain_var, 0.0)) / max(norm / math.sqrt(3), 1.0),
                    grain_var / se, (0.05 * norm / math.sqrt(3)) ** 2 / se, row[KEPT] / row[N]))
    return out


def _evidence_py(grain, z, even, grain_metal, grain_z_min):
    if grain >= grain_metal:
        need = grain_z_min
    elif grain >= 0.5 * grain_metal and even >= 0.2:
        need = grain_z_min + 2.0 * (1.0 - grain / grain_metal)
    else:
        return 0.0
    return min(max((z - need) / 0.5 + 1.0, 0.0), 1.0)


def _labels_py(albedo, grain, grain_metal, grain_z_min, albedo_sigma):
    prior = _albedo_metal_probability(albedo, albedo_sigma).tolist()
    bright = (albedo.sum(axis=1) / 3 >= 0.25).tolist()
    out = []
    for (g, z, vis, even), p, lit in zip(grain, prior, bright, strict=True):
        p = min(max(p, 0.05), 0.95)
        odds = p / (1 - p)
        evidence = _evidence_py(g, z, even, grain_metal, grain_z_min) if lit else 0.0
        if evidence > 0.0:
            odds *= 50.0**evidence
        elif lit and g < 0.45 * grain_metal and vis >= 6.0:
            odds *= 1.0 / 50.0
        p = odds / (1 + odds)
        out.append(("metal", p) if p >= 0.5 else ("plastic", 1 - p))
    return out


def _stats(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    s = np.zeros((n, N_STATS))
    s[:, N] = rng.integers(8, 4000, n)
    s[:, KEPT] = np.floor(s[:, N] * rng.uniform(0.0, 0.6, n))
    s[:, MEAN : MEAN + 3] = rng.uniform(0, 255, (n, 3))
    s[:, NORM] = np.linalg.norm(s[:, MEAN : MEAN + 3], axis=1)
    s[:, S_PAR] = rng.uniform(0, 12, n)
    s[:, S_NOISE2] = rng.uniform(-1, 100, n)
    return s


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 12), st.floats(0, 8), st.floats(0.01, 0.1),
       st.floats(1, 5), st.floats(0.05, 0.3))
def test_compiled_labels_are_the_python_formulation(seed, n, noise, grain_metal, z_min, sigma):
    stats = _stats(seed, n)
    grain = _grain(stats, noise)
    assert grain.tolist() == [list(g) for g in _grain_py(stats, noise)]
    albedo = np.random.default_rng(seed + 1).uniform(0, 1.2, (n, 3))
    got = _labels(albedo, grain, grain_metal, z_min, sigma)
    assert got == _labels_py(albedo, grain.tolist(), grain_metal, z_min, sigma)
