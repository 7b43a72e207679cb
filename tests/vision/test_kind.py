"""Kind from footprint descriptors, and yaw modulo symmetry, on exact catalogue outlines."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cell.catalogue import KINDS
from cell.errors import VisionError
from cell.vision.kind import classify_kind, footprint, footprint_yaw, score_kind


def _ring(shape: str, apothem: float, n: int = 96) -> np.ndarray:
    t = np.arange(n) * 2 * math.pi / n
    if shape == "circle":
        r = np.full(n, apothem)
    else:
        sides = 6 if shape == "hex" else 4
        off = math.pi / sides if shape == "hex" else 0.0
        sector = 2 * math.pi / sides
        r = apothem / np.cos(np.mod(t - off + sector / 2, sector) - sector / 2)
    return np.stack([r * np.cos(t), r * np.sin(t)], axis=1)


def _l_bracket() -> np.ndarray:
    """The sim's L (cell.sim.parts): outer corner at -x, -y, long leg along +x, centred."""
    pts = np.array([[0, 0], [40, 0], [40, 12], [12, 12], [12, 30], [0, 30]], float) * 1e-3
    c = np.array([(480 * 20 + 216 * 6) / 696, (480 * 6 + 216 * 21) / 696]) * 1e-3
    return pts - c


def _bolt() -> np.ndarray:
    """A bolt as its outline renders: head 11 mm wide, shank outlined 5 mm wide."""
    return np.array([[-22, -5.5], [-18, -5.5], [-18, -2.5], [22, -2.5], [22, 2.5], [-18, 2.5],
                     [-18, 5.5], [-22, 5.5]], float) * 1e-3


OUTLINES = {
    "washer": (_ring("circle", 0.010), [_ring("circle", 0.00525)]),
    "hex_nut": (_ring("hex", 0.0085), [_ring("circle", 0.005)]),
    "square_nut": (_ring("square", 0.0065), [_ring("circle", 0.004)]),
    "bolt": (_bolt(), []),
    "l_bracket": (_l_bracket(), []),
    "disc": (_ring("circle", 0.015), []),
}


def _turn(poly: np.ndarray, yaw: float, at=(0.3, 0.45)) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return poly @ np.array([[c, s], [-s, c]]) + np.array(at)


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("yaw", [0.0, 0.4, 2.5])
def test_each_catalogue_outline_is_its_kind(kind, yaw):
    outline, holes = OUTLINES[kind]
    fp = footprint(_turn(outline, yaw), [_turn(h, yaw) for h in holes])
    label, conf, fit = classify_kind({k: score_kind(fp, k) for k in KINDS})
    assert label == kind and conf > 0.9 and fit < 4


def test_descriptors_of_a_washer():
    outline, holes = OUTLINES["washer"]
    fp = footprint(outline, holes)
    assert fp.length == pytest.approx(0.020, abs=2e-4)
    assert fp.hole_fraction == pytest.approx((10.5 / 20) ** 2, abs=0.01)
    assert fp.solidity == pytest.approx(1.0, abs=0.01)
    np.testing.assert_allclose(fp.centroid, [0, 0], atol=1e-6)


def test_l_bracket_centroid_and_solidity():
    fp = footprint(_turn(_l_bracket(), 1.0))
    np.testing.assert_allclose(fp.centroid, [0.3, 0.45], atol=1e-6)
    assert fp.solidity == pytest.approx(696 / (1200 - 0.5 * 28 * 18), abs=0.01)


@pytest.mark.parametrize("kind", ["hex_nut", "square_nut", "bolt", "l_bracket"])
@pytest.mark.parametrize("yaw", [0.1, 1.3, 2.9, 4.4, 5.9])
def test_yaw_modulo_symmetry(kind, yaw):
    outline, holes = OUTLINES[kind]
    fp = footprint(_turn(outline, yaw), [_turn(h, yaw) for h in holes])
    period = 2 * math.pi / KINDS[kind].symmetry
    got = footprint_yaw(fp, kind)
    assert 0 <= got < period
    e = (got - yaw) % period
    assert min(e, period - e) < math.radians(0.5)


def test_continuous_symmetry_has_yaw_zero():
    outline, holes = OUTLINES["disc"]
    assert footprint_yaw(footprint(outline, holes), "disc") == 0.0


def test_a_shape_fitting_nothing_is_unknown():
    blob = _ring("circle", 0.05)  # 100 mm: no such part
    fp = footprint(blob)
    assert classify_kind({k: score_kind(fp, k) for k in KINDS})[0] == "unknown"


def test_bad_input():
    with pytest.raises(VisionError, match="outline"):
        footprint(np.zeros((2, 2)))
    with pytest.raises(VisionError, match="kind"):
        score_kind(footprint(_ring("circle", 0.01)), "gear")


@pytest.mark.parametrize("seed", range(10))
def test_noisy_outlines_keep_hex_nuts_and_washers_apart(seed):
    """Outline points jittered by 0.4 mm (about the pixel size on the belt, as in dim,
    noisy frames): the facet strength comes from the hull's edges, which run along the
    flats, so a hex nut stays a hex nut (the outline's own short chords read it round)
    and a washer stays round."""
    rng = np.random.default_rng(seed)
    for kind, shape, size in (("hex_nut", "hex", 0.0085), ("washer", "circle", 0.010)):
        ring = _ring(shape, size, n=160)
        ring = ring + rng.normal(0.0, 0.0004, ring.shape)
        holes = OUTLINES[kind][1]
        fp = footprint(_turn(ring, 0.7), [_turn(h, 0.7) for h in holes])
        assert classify_kind({k: score_kind(fp, k) for k in KINDS})[0] == kind


def test_score_kinds_equals_score_kind_per_kind():
    from cell.vision.kind import KIND_NAMES, score_kinds

    for kind, (outline, holes) in OUTLINES.items():
        fp = footprint(_turn(outline, 0.4), [_turn(h, 0.4) for h in holes])
        np.testing.assert_allclose(score_kinds(fp), [score_kind(fp, k) for k in KIND_NAMES],
                                   rtol=1e-12, err_msg=kind)


def test_l_bracket_yaw_is_not_turned_by_a_bulge_on_one_side():
    """A shadow glued to one leg turns the min-area rectangle; the yaw follows the
    edges' 4-fold mean direction instead, off by half as much or less."""
    pts = np.array([[0, 0], [40, 0], [40, 12], [12, 12], [12, 30], [0, 30]], float)
    dense = np.concatenate([np.linspace(a, b, 40, endpoint=False)
                            for a, b in zip(pts, np.roll(pts, -1, axis=0), strict=True)])
    # a wedge-shaped shadow along the long leg's outer edge: 0 mm at x=0, 3 mm at x=40
    on_edge = dense[:, 1] < 1e-9
    dense[on_edge, 1] -= 3.0 * dense[on_edge, 0] / 40
    poly = (dense - dense.mean(axis=0)) * 1e-3
    yaw = 0.6
    fp = footprint(_turn(poly, yaw))
    rect_err = abs(math.degrees(np.angle(np.exp(1j * 4 * (fp.rect_angle - yaw))) / 4))
    assert rect_err > 2.0  # the rectangle is turned by the wedge...
    e = (footprint_yaw(fp, "l_bracket") - yaw) % (2 * math.pi)
    assert math.degrees(min(e, 2 * math.pi - e)) < 0.5 * rect_err  # ...the yaw much less


def test_nut_yaw_leaves_out_the_cut_from_a_touching_part():
    """A square nut whose outline lost a corner to a straight cut (where it touched another
    part): told where the cut is, the yaw ignores it; not told, the cut's slant turns it."""
    yaw = 0.3
    ring = _turn(_ring("square", 0.0065, n=240), yaw)
    # cut a slice off one side with a chord 20 deg off the flats, sampled like a traced edge
    d = np.array([math.cos(yaw + math.radians(20)), math.sin(yaw + math.radians(20))])
    keep = (ring - np.array([0.3, 0.45])) @ d < 0.004
    start = int(np.argmin(keep))  # first point removed
    ring = np.roll(ring, -start, axis=0)
    keep = np.roll(keep, -start)
    kept = ring[keep]
    cut = np.linspace(kept[-1], kept[0], 30)[1:-1]
    outline = np.concatenate([kept, cut])
    fp = footprint(outline, [_turn(h, yaw) for h in OUTLINES["square_nut"][1]])
    period = math.pi / 2

    def err(y):
        e = (y - yaw) % period
        return math.degrees(min(e, period - e))

    assert err(footprint_yaw(fp, "square_nut", cut=len(cut))) < 0.3
    assert err(footprint_yaw(fp, "square_nut")) > 2 * err(footprint_yaw(fp, "square_nut", cut=len(cut)))
