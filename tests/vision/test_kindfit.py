"""The compiled kind fit (cell.vision._kindfit) against its plain formulation: the
footprints mapped with per-point height arrays, described, scored and classified, the
chosen footprint copied out (to the last bit)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cell.vision import _footprint as fp
from cell.vision._kindfit import _bolt_heights, _classify, _map, _map_at, _score, fit_one
from cell.vision._polygons import describe_one
from cell.vision.kind import MAX_FIT, SCORING

_DROP = -0.5  # the plane 0.5 m below a camera at the world's origin
_ARGS = (0.0, 0.0, _DROP, fp._MID, fp._EDGE_LO, fp._EDGE_HI, fp._BOLT, fp.KINDS["bolt"].height,
         *SCORING, MAX_FIT, fp._ROUGH_HOPELESS, fp._REFINE_GAP, 0.5)


def _reference(rays, away, local, args):
    """fit_one as first written: height arrays, a footprint per try, slice copies."""
    (ox, oy, drop, mid, edge_lo, edge_hi, bolt, bolt_height, nominal, sigmas, round_,
     round_facets, faceted, facet_w, max_fit, hopeless, gap, min_conf) = args
    n = len(rays)
    idx = np.arange(n)
    lo, hi = np.full(n, mid), np.full(n, mid)
    mid_xy, mid_row = np.empty((n, 2)), np.empty(10)
    _map(rays, away, idx, 0, n, lo, hi, ox, oy, drop, mid_xy)
    describe_one(mid_xy, local, mid_row)
    score = [_score(mid_row, k, nominal, sigmas, round_, round_facets, faceted, facet_w)
             for k in range(len(nominal))]
    rough = np.array(score)
    a = int(np.argmin(rough))
    b = min((k for k in range(len(rough)) if k != a), key=lambda k: (rough[k], k))
    xy, row = mid_xy.copy(), mid_row.copy()
    if rough[a] > hopeless:
        return -1, 0.0, math.inf, xy, row
    tried = (a, b) if rough[b] <= rough[a] + gap else (a,)
    refined = {}
    for k in tried:
        if k == bolt:
            _bolt_heights(mid_xy, mid_row, bolt_height, lo, hi)
        else:
            lo[:], hi[:] = edge_lo[k], edge_hi[k]
        r_xy, r_row = np.empty((n, 2)), np.empty(10)
        _map(rays, away, idx, 0, n, lo, hi, ox, oy, drop, r_xy)
        describe_one(r_xy, local, r_row)
        rough[k] = _score(r_row, k, nominal, sigmas, round_, round_facets, faceted, facet_w)
        refined[k] = (r_xy, r_row)
    best, c, f = _classify(rough, max_fit)
    if best < 0 or c < min_conf:
        return -1, c, f, xy, row
    return best, c, f, *refined[best]


def _outline(kind: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Plane points (m) of an outline (and its hole, if any) of roughly a kind's shape,
    with a little noise; returns (points, polygon ends)."""
    t = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    centre = rng.uniform(-0.1, 0.1, 2)
    if kind == "washer":
        outer = 0.0101 * np.stack([np.cos(t), np.sin(t)], 1)
        hole = 0.0053 * np.stack([np.cos(t[::-1]), np.sin(t[::-1])], 1)
        pts, ends = np.concatenate([outer, hole]), [120, 240]
    elif kind == "bolt":
        pts = np.array([[-22, -5.5], [-18, -5.5], [-18, -2.5], [22, -2.5], [22, 2.5],
                        [-18, 2.5], [-18, 5.5], [-22, 5.5]], float) * 1e-3
        pts = np.concatenate([np.linspace(p, q, 15, endpoint=False)
                              for p, q in zip(pts, np.roll(pts, -1, 0), strict=True)])
        ends = [len(pts)]
    else:  # two discs touching: no kind
        a = 0.015 * np.stack([np.cos(t), np.sin(t)], 1)
        pts = np.concatenate([a[:60] + [0.014, 0], a[60:] - [0.014, 0]])
        ends = [len(pts)]
    pts = pts + centre + rng.normal(0, 2e-5, pts.shape)
    return pts, np.array(ends)


@pytest.mark.parametrize("kind", ["washer", "bolt", "none"])
@pytest.mark.parametrize("seed", range(4))
def test_fit_one_is_its_plain_formulation(kind, seed):
    rng = np.random.default_rng(seed)
    pts, ends = _outline(kind, rng)
    away = rng.random(len(pts)) < 0.5
    rays = pts / (_DROP + np.where(away, 0.004, 0.0))[:, None]  # some edges raised
    local = np.concatenate([[0], ends]).astype(np.int64)
    xy, row = np.empty((len(pts), 2)), np.empty(10)
    got = fit_one(rays, away, np.arange(len(pts)), 0, len(pts), local, *_ARGS, xy, row)
    want = _reference(rays, away, local, _ARGS)
    assert got == want[:3]
    np.testing.assert_allclose(xy, want[3], rtol=1e-9, atol=1e-12)  # compiled vs numpy: FMA
    np.testing.assert_allclose(row, want[4], rtol=1e-9, atol=1e-12)


def test_map_at_is_map_with_constant_heights():
    rng = np.random.default_rng(0)
    rays = rng.normal(0, 0.3, (50, 2))
    away = rng.random(50) < 0.4
    idx = rng.permutation(50)
    for lo, hi in ((0.0025, 0.0025), (0.0, 0.0065), (0.0035, 0.002)):
        a, b = np.empty((30, 2)), np.empty((30, 2))
        _map(rays, away, idx, 10, 40, np.full(30, lo), np.full(30, hi), 0.1, -0.2, -0.6, a)
        _map_at(rays, away, idx, 10, 40, lo, hi, 0.1, -0.2, -0.6, b)
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)
