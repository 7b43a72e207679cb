"""Step 4: touching parts cut apart, each piece fitting its kind where it lies."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cell.vision.settings import VisionSettings
from cell.vision.steps.footprint import TablePlane
from cell.vision.steps.foreground import find_foreground
from cell.vision.steps.kind import fit_kind
from cell.vision.steps.outlines import find_outlines
from cell.vision.steps.split import split_blob
from tests.vision.steps import drawn


def _pieces(draw, *, faint_contrast: float = 0.0):
    img = drawn.frame()
    draw(img)
    fg = find_foreground(img, VisionSettings())
    (blob,) = find_outlines(fg, VisionSettings(), min_px=50, max_px=180)
    plane = TablePlane(drawn.camera(), 0.08)
    whole = fit_kind(blob, plane)
    pieces = split_blob(blob, whole, foreground=fg, plane=plane, faint_contrast=faint_contrast)
    return whole, pieces, plane


def test_two_touching_discs_come_out_as_two_discs_where_they_lie():
    def two(img):
        for x in (-15, 15):  # 30 mm discs, edge to edge
            cv2.circle(img, drawn.mm(x, 0), drawn.px(15), (200, 200, 195), -1)
    whole, pieces, _ = _pieces(two)
    assert whole.kind == "unknown"
    assert sorted(p.fit.kind for p in pieces) == ["disc", "disc"]
    xs = sorted(p.fit.footprint.centroid[0] * 1e3 for p in pieces)
    assert xs == pytest.approx([-15, 15], abs=1.0)


def test_a_nut_touching_a_brackets_end_is_cut_off_it():
    def bracket_and_nut(img):
        cv2.rectangle(img, drawn.mm(-40, 6), drawn.mm(0, -6), (200, 200, 195), -1)  # long leg
        cv2.rectangle(img, drawn.mm(-40, 24), drawn.mm(-28, 6), (200, 200, 195), -1)  # short leg
        cv2.rectangle(img, drawn.mm(0, 9.5), drawn.mm(13, -3.5), (200, 200, 195), -1)  # a nut
        cv2.circle(img, drawn.mm(6.5, 3), drawn.px(4), drawn.BELT, -1)  # its hole
    _, pieces, _ = _pieces(bracket_and_nut)
    assert sorted(p.fit.kind for p in pieces) == ["l_bracket", "square_nut"]
    nut = next(p for p in pieces if p.fit.kind == "square_nut")
    assert nut.fit.footprint.centroid[0] * 1e3 == pytest.approx(6.5, abs=1.0)
    assert nut.cut is not None and nut.cut.any()  # the cut is marked, for the yaw


def test_the_points_a_cut_piece_marks_as_cut_are_on_the_cut():
    """The pose step leaves the footprint points marked ``cut`` out of a piece's yaw: they
    must be the cut's (the nut's left side, x = 0), in the footprint as in the ring."""
    def bracket_and_nut(img):
        cv2.rectangle(img, drawn.mm(-40, 6), drawn.mm(0, -6), (200, 200, 195), -1)
        cv2.rectangle(img, drawn.mm(-40, 24), drawn.mm(-28, 6), (200, 200, 195), -1)
        cv2.rectangle(img, drawn.mm(0, 9.5), drawn.mm(13, -3.5), (200, 200, 195), -1)
        cv2.circle(img, drawn.mm(6.5, 3), drawn.px(4), drawn.BELT, -1)
    _, pieces, plane = _pieces(bracket_and_nut)
    nut = next(p for p in pieces if p.fit.kind == "square_nut")
    on_cut = nut.fit.footprint.outline[nut.cut] * 1e3  # mm
    assert np.abs(on_cut[:, 0]).max() < 1.5  # (a 1.5 px band: 0.9 mm, and the edge's half pixel)
    ring = plane.points(nut.blob.outer.points[nut.cut], 0.0) * 1e3
    assert np.abs(ring[:, 0]).max() < 1.5


def test_one_part_is_not_cut():
    _, pieces, _ = _pieces(lambda img: cv2.circle(img, drawn.mm(0, 0), drawn.px(15), (200, 200, 195), -1))
    assert pieces == []


def test_the_middle_part_of_a_row_has_both_its_cuts_marked():
    """Three discs in a row: the blob is cut once, then the piece of two again; the middle
    disc's outline touches both cuts, and the points on each are marked (x = -15, +15 mm)."""
    def row(img):
        for x in (-30, 0, 30):
            cv2.circle(img, drawn.mm(x, 0), drawn.px(15), (200, 200, 195), -1)
    _, pieces, _ = _pieces(row)
    assert [p.fit.kind for p in pieces] == ["disc"] * 3
    middle = min(pieces, key=lambda p: abs(p.fit.footprint.centroid[0]))
    on_cut = middle.fit.footprint.outline[middle.cut] * 1e3  # mm
    assert on_cut[:, 0] == pytest.approx(np.where(on_cut[:, 0] < 0, -15.0, 15.0), abs=1.5)
    assert (on_cut[:, 0] < 0).any() and (on_cut[:, 0] > 0).any()


def test_a_third_part_touching_at_a_corner_only_is_kept():
    """The cut between two discs leaves a square nut that touches one of them at a corner
    only (one diagonal step, no shared edge) as a piece of its own: no cut may drop it."""
    def three(img):
        cv2.circle(img, drawn.mm(-30, 0), drawn.px(15), (60, 160, 60), -1)
        cv2.circle(img, drawn.mm(0, 0), drawn.px(15), (200, 200, 195), -1)
        u, v = drawn.mm(0, 0)
        disc = np.all(img == (200, 200, 195), axis=2)
        # the first corner of the right disc's staircase up and to the right (its pixels
        # to the right and above are belt): the nut's lower-left corner goes beside it
        x, y = min((x, y) for y in range(v - 30, v) for x in range(u + 1, u + 30)
                   if disc[y, x] and not disc[y, x + 1] and not disc[y - 1, x])
        side = drawn.px(13)
        x0, y1 = x + 1, y - 1  # the nut's lower-left corner pixel
        cv2.rectangle(img, (x0, y1 - side + 1), (x0 + side - 1, y1), (200, 60, 50), -1)
        cv2.circle(img, (x0 + side // 2, y1 - side // 2), drawn.px(4), drawn.BELT, -1)
    _, pieces, _ = _pieces(three)
    assert sorted(p.fit.kind for p in pieces) == ["disc", "disc", "square_nut"]


def test_every_sizeable_region_of_a_colour_seeds_the_colour_cut():
    """A black part whose face a streak of the other colour (the belt's light on a bevel)
    breaks in two, beside a blue one: both black regions seed the black piece, not only
    the larger, so the smaller does not go to the blue piece it lies nearer to; small blue
    regions seed nothing."""
    from cell.vision.steps.material import PartPixels
    from cell.vision.steps.split import _colour_seeds

    img = np.zeros((60, 80, 3), np.uint8)
    img[:, :40] = (30, 60, 200)  # blue
    img[:, 40:] = (25, 25, 28)  # black, broken at column 52 by a blue streak
    img[:, 51:54] = (30, 60, 200)
    img[28:31, 65:68] = (30, 60, 200)  # a blue speck in the black
    seeds = _colour_seeds(PartPixels(0, 0, np.full((60, 80), 255, np.uint8)), img)
    black = seeds[30, 70]
    assert seeds[30, 46] == black != seeds[30, 20] > 0  # both black regions, one label
    assert seeds[29, 66] in (0, black) and seeds[30, 52] in (0, black)  # no blue seeds


def test_colour_cut_leaves_the_callers_opencv_generator_alone():
    """The colour clusters' k-means++ start is seeded in a thread of its own: a caller who
    seeded OpenCV's generator draws the same numbers with or without a colour cut between,
    and the same blob gives the same seeds every time."""
    from cell.vision.steps.material import PartPixels
    from cell.vision.steps.split import _colour_seeds

    img = np.zeros((60, 80, 3), np.uint8)
    img[:, :40] = (30, 60, 200)
    img[:, 40:] = (200, 180, 40)
    noise = np.random.default_rng(3).integers(0, 12, img.shape, dtype=np.uint8)
    img = cv2.add(img, noise)
    pixels = PartPixels(0, 0, np.full((60, 80), 255, np.uint8))

    def draws() -> np.ndarray:
        out = np.zeros(8, np.float32)
        cv2.randu(out, 0.0, 1.0)
        return out

    cv2.setRNGSeed(1234)
    expected = draws()
    cv2.setRNGSeed(1234)
    first = _colour_seeds(pixels, img)
    assert np.array_equal(draws(), expected)
    assert first is not None and np.array_equal(_colour_seeds(pixels, img), first)


def test_each_straight_cut_is_tried_once():
    """Two notches facing each other across a waist: the cut between them is also each
    one's nearest point across; it is one candidate, not three (each costs a fit)."""
    from cell.vision.steps.split import _notch_cuts

    mask = np.zeros((40, 80), np.uint8)
    cv2.rectangle(mask, (10, 10), (70, 30), 255, -1)
    cv2.fillPoly(mask, [np.array([[30, 10], [50, 10], [40, 17]], np.int32)], 0)
    cv2.fillPoly(mask, [np.array([[30, 30], [50, 30], [40, 23]], np.int32)], 0)
    cuts = [sorted((tuple(a), tuple(b))) for a, b in _notch_cuts(mask)]
    assert cuts == [[(40.0, 18.0), (40.0, 22.0)]]


def _disc_touching_a_smudge(img, *, lift: int = 12):
    """A bright 30 mm disc touching a faint smudge (28 x 18 mm, ``lift`` grey levels over
    the belt in every channel: a grey part at the noise level under dim light)."""
    faint = tuple(int(c) + lift for c in drawn.BELT)
    cv2.ellipse(img, drawn.mm(-20, 0), (drawn.px(14), drawn.px(9)), 0, 0, 360, faint, -1)
    cv2.circle(img, drawn.mm(8, 0), drawn.px(15), (200, 200, 195), -1)


def test_a_part_touching_faint_fragments_is_cut_off_them_and_they_are_left_out():
    """The smudge fits no kind, so no cut has two pieces that fit: a faint piece is left
    out (it stands 1.5 thresholds from the belt, under vision.faint_contrast's 1.85)."""
    whole, pieces, _ = _pieces(_disc_touching_a_smudge, faint_contrast=1.85)
    assert whole.kind == "unknown"
    assert [p.fit.kind for p in pieces] == ["disc"]
    assert pieces[0].fit.footprint.centroid[0] * 1e3 == pytest.approx(8, abs=1.0)
    _, unchanged, _ = _pieces(_disc_touching_a_smudge, faint_contrast=0.0)  # 0: none faint
    assert unchanged == []


def test_a_bright_piece_that_fits_no_kind_still_fails_the_cut():
    """The same smudge drawn 30 grey levels over the belt (3.75 thresholds) is no fragment
    of a faint part: a cut that leaves a piece fitting no kind is not taken."""
    whole, pieces, _ = _pieces(lambda img: _disc_touching_a_smudge(img, lift=30),
                               faint_contrast=1.85)
    assert whole.kind == "unknown" and whole.footprint.length > 0.05  # the disc and the smudge
    assert pieces == []


def test_a_cut_whose_pieces_all_fit_wins_over_one_that_leaves_a_faint_piece_out():
    """Two touching discs, one of them faint: both are reported, the faint one too (its
    outline is whole here), rather than the bright one alone."""
    def two(img):
        faint = tuple(int(c) + 12 for c in drawn.BELT)
        cv2.circle(img, drawn.mm(-15, 0), drawn.px(15), faint, -1)
        cv2.circle(img, drawn.mm(15, 0), drawn.px(15), (200, 200, 195), -1)
    _, pieces, _ = _pieces(two, faint_contrast=1.85)
    xs = sorted(round(p.fit.footprint.centroid[0] * 1e3) for p in pieces)
    assert [p.fit.kind for p in pieces] == ["disc", "disc"] and xs == pytest.approx([-15, 15], abs=1)


def test_split_blob_names_a_wrong_foreground_or_faint_contrast():
    from cell.errors import VisionError

    img = drawn.frame()
    cv2.circle(img, drawn.mm(0, 0), drawn.px(15), (200, 200, 195), -1)
    fg = find_foreground(img, VisionSettings())
    (blob,) = find_outlines(fg, VisionSettings(), min_px=50, max_px=180)
    plane = TablePlane(drawn.camera(), 0.08)
    with pytest.raises(VisionError, match="foreground"):
        split_blob(blob, fit_kind(blob, plane), foreground=img, plane=plane)
    for bad in (float("nan"), -1.0, 21.0, "2"):
        with pytest.raises(VisionError, match="faint_contrast"):
            split_blob(blob, fit_kind(blob, plane), foreground=fg, plane=plane, faint_contrast=bad)
