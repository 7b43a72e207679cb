"""Compiled grain features and material odds of every part of a frame (numba).

:func:`grain_rows` turns pixel statistics rows (:mod:`cell.vision._material_kernel`) into
(grain, grain_z, grain_visibility, even-light fraction), :func:`metal_prior` gives the
albedo's P(metal) against the catalogue finishes, :func:`metal_odds` turns those two into
each part's P(metal): the formulas of :mod:`cell.vision.material`
(which documents them), in one call for all parts instead of a Python loop.

Python's ``x ** 2`` of a float is libm's ``pow``, which rounds differently from
``x * x`` in about 1 case in 1200; LLVM turns a ``pow`` by a constant 2 into ``x * x``,
so the kernels take the exponent as an argument (``two``, 2.0) and call ``pow`` as Python
does: the results equal the Python formulation's bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from cell.vision._material_kernel import KEPT, MEAN, NORM, S_NOISE2, S_PAR, N

__all__: list[str] = []  # private to cell.vision

HIGHPASS_GAIN = math.sqrt((8 / 9) ** 2 + 8 / 81)  # white noise through I - box3x3(I)
GRAIN_ODDS = 50.0  # the odds clear grain (or its clear absence) multiplies
SOFT_Z = 0.5  # standard errors below grain_z_min over which grain's weight rises
WEAK, Z_PER_DEFICIT, EVEN = 0.5, 2.0, 0.2  # weak grain: see grain_evidence


@njit(cache=True)
def grain_rows(stats, noise_sigma, two, out):  # pragma: no cover (compiled)
    """(grain, grain_z, grain_visibility, grain_pixels / pixels) (P, 4) of statistics rows
    (P, N_STATS), the noise floored at the frame's ``noise_sigma`` through the high-pass."""
    floor = noise_sigma * HIGHPASS_GAIN
    for i in range(stats.shape[0]):
        row = stats[i]
        norm, s_par = row[NORM], row[S_PAR]
        s_noise = max(math.sqrt(max(row[S_NOISE2], 0.0)) / 1.1774, floor)  # Rayleigh median
        grain_var = s_par**two - s_noise**two
        se = math.sqrt(2.0 / (0.37 * max(row[KEPT], 1.0))) * (s_par**two + s_noise**two) + 1e-9
        out[i, 0] = math.sqrt(max(grain_var, 0.0)) / max(norm / math.sqrt(3), 1.0)
        out[i, 1] = grain_var / se
        out[i, 2] = (0.05 * norm / math.sqrt(3)) ** two / se
        out[i, 3] = row[KEPT] / row[N]


@njit(cache=True)
def grain_evidence(grain, z, even, grain_metal, grain_z_min):  # pragma: no cover (compiled)
    """How much of the grain's full weight (0..1) a part's grain carries.

    Full from ``grain_metal`` and ``grain_z_min``; over the last ``SOFT_Z`` standard
    errors below that it rises linearly, so one pixel more or less in the interior does not
    flip a label. A weaker grain, down to ``WEAK`` * ``grain_metal`` (a metal under a
    specular spot: its mean brightness rises, the grain does not), counts where the
    evidence is the stronger for it, ``Z_PER_DEFICIT`` standard errors more at half
    ``grain_metal``, and only on an evenly lit surface (at least ``EVEN`` of its pixels
    flat and lit: under directional light the shading of a thread passes for weak grain).
    """
    if grain >= grain_metal:
        need = grain_z_min
    elif grain >= WEAK * grain_metal and even >= EVEN:
        need = grain_z_min + Z_PER_DEFICIT * (1.0 - grain / grain_metal)
    else:
        return 0.0
    return min(max((z - need) / SOFT_Z + 1.0, 0.0), 1.0)


@njit(cache=True)
def metal_odds(albedo, grain, prior, grain_metal, grain_z_min, out):  # pragma: no cover
    """P(metal) (P,) of parts from their albedos (P, 3), grain rows (P, 4) as
    :func:`grain_rows` gives and albedo priors (P,): the prior held within 0.05..0.95, its
    odds multiplied by the grain's evidence."""
    for i in range(albedo.shape[0]):
        g, z, vis, even = grain[i, 0], grain[i, 1], grain[i, 2], grain[i, 3]
        lit = (albedo[i, 0] + albedo[i, 1] + albedo[i, 2]) / 3 >= 0.25  # as ndarray.mean
        p = min(max(prior[i], 0.05), 0.95)
        odds = p / (1 - p)
        evidence = grain_evidence(g, z, even, grain_metal, grain_z_min) if lit else 0.0
        if evidence > 0.0:
            odds *= GRAIN_ODDS**evidence
        elif lit and g < 0.45 * grain_metal and vis >= 6.0:
            odds *= 1.0 / GRAIN_ODDS
        out[i] = odds / (1 + odds)


@njit(cache=True)
def metal_prior(albedo, finishes, metal, sigma2):  # pragma: no cover (compiled)
    """P(metal) (P,) of albedos (P, 3) from the finishes' albedos (K, 3) and whether each is
    a metal (K,) bool: the share of the metals in the softmax of -d2 / 2, d2 the squared
    distance over ``sigma2``; sums in numpy's order (``ndarray.sum``: pairwise in blocks
    of 8), so the result is numpy's bit for bit."""
    out = np.empty(albedo.shape[0])
    n_k = finishes.shape[0]
    d2 = np.empty(n_k)
    w = np.empty(n_k)
    metals = np.empty(n_k)
    for q in range(albedo.shape[0]):
        for k in range(n_k):
            a = finishes[k, 0] - albedo[q, 0]
            b = finishes[k, 1] - albedo[q, 1]
            c = finishes[k, 2] - albedo[q, 2]
            d2[k] = (a * a + b * b + c * c) / sigma2
        low = d2.min()
        m = 0
        for k in range(n_k):
            w[k] = math.exp(-(d2[k] - low) / 2)
            if metal[k]:
                metals[m] = w[k]
                m += 1
        out[q] = _numpy_sum(metals[:m]) / _numpy_sum(w)
    return out


@njit(cache=True)
def _numpy_sum(v):  # pragma: no cover (compiled)
    """``v.sum()`` of at most 128 values in numpy's order (pairwise_sum: under 8 values in
    turn; else 8 running sums of every 8th value, added pairwise, then the rest in turn)."""
    n = v.shape[0]
    if n < 8:
        s = -0.0
        for i in range(n):
            s += v[i]
        return s
    r = v[:8].copy()
    top = n - n % 8
    for i in range(8, top, 8):
        for j in range(8):
            r[j] += v[i + j]
    s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    for i in range(top, n):
        s += v[i]
    return s


@njit(cache=True)
def metal_probabilities(stats, belts, belt_rgb, noise_sigma, two, grain_metal, grain_z_min,
                        finishes, metal, sigma2, out):  # pragma: no cover (compiled)
    """P(metal) (P,) of parts from their statistics rows (P, N_STATS) and the belt's colour
    next to each (P, 3): the white-balanced albedo (mean colour over the belt's, at least
    1, times its reflectance ``belt_rgb``), :func:`grain_rows`, :func:`metal_prior` and
    :func:`metal_odds` in one call."""
    p = stats.shape[0]
    albedo = np.empty((p, 3))
    for i in range(p):
        for c in range(3):
            albedo[i, c] = stats[i, MEAN + c] / max(belts[i, c], 1.0) * belt_rgb[c]
    grain = np.empty((p, 4))
    grain_rows(stats, noise_sigma, two, grain)
    metal_odds(albedo, grain, metal_prior(albedo, finishes, metal, sigma2), grain_metal,
               grain_z_min, out)
