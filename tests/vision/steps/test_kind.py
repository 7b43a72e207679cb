"""Step 3b: kinds from footprints; confidence falls with the fit; no kind, unknown."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cell.catalogue import KINDS
from cell.vision.settings import VisionSettings
from cell.vision.steps.footprint import TablePlane, describe
from cell.vision.steps.foreground import find_foreground
from cell.vision.steps.kind import KIND_NAMES, classify_kind, fit_kind, score_kinds
from cell.vision.steps.outlines import find_outlines
from tests.vision.steps import drawn


def _circle(r: float, n: int = 96) -> np.ndarray:
    a = np.arange(n) * 2 * np.pi / n
    return np.stack([r * np.cos(a), r * np.sin(a)], 1)


def test_a_washer_footprint_is_a_washer_and_a_disc_a_disc():
    washer = describe(_circle(0.010), (_circle(0.00525),))
    disc = describe(_circle(0.015))
    for fp, kind in ((washer, "washer"), (disc, "disc")):
        scores = score_kinds(fp)
        assert KIND_NAMES[int(np.argmin(scores))] == kind
        name, confidence = classify_kind(scores)
        assert name == kind and confidence > 0.9


def test_confidence_falls_as_even_the_best_kind_fits_worse():
    base = np.array([30.0] * len(KINDS))
    confidences = []
    for best in (0.5, 4.0, 8.0, 12.0, 15.9):
        scores = base.copy()
        scores[0] = best
        confidences.append(classify_kind(scores, min_confidence=0.0)[1])
    assert confidences[0] == pytest.approx(confidences[1], abs=1e-4) and confidences[0] > 0.99
    assert all(a > b for a, b in zip(confidences[1:], confidences[2:], strict=False))
    assert confidences[-1] == pytest.approx(0.5, abs=0.01)
    assert classify_kind(base) == ("unknown", 0.0)


def _drawn_blob(draw) -> tuple:
    img = drawn.frame()
    draw(img)
    fg = find_foreground(img, VisionSettings())
    (blob,) = find_outlines(fg, VisionSettings(), min_px=50, max_px=180)
    return blob, TablePlane(drawn.camera(), 0.08)


def test_a_solid_disc_of_a_washers_size_is_no_washer():
    """A 20 mm disc with no hole matches the washer's size but not its hole: unknown."""
    blob, plane = _drawn_blob(lambda img: cv2.circle(img, drawn.mm(0, 0), drawn.px(10), (200, 200, 195), -1))
    fit = fit_kind(blob, plane)
    assert fit.kind == "unknown" and fit.confidence == 0.0
    assert fit.footprint.length == pytest.approx(0.020, abs=0.001)


def test_a_drawn_washer_is_a_washer():
    def washer(img):
        cv2.circle(img, drawn.mm(0, 0), drawn.px(10), (200, 200, 195), -1)
        cv2.circle(img, drawn.mm(0, 0), drawn.px(5.25), drawn.BELT, -1)
    blob, plane = _drawn_blob(washer)
    fit = fit_kind(blob, plane)
    assert fit.kind == "washer" and fit.confidence > 0.9
    u, v = drawn.mm(0, 0)  # (the circle's centre, rounded to a pixel)
    want = ((u - (drawn.W - 1) / 2) / drawn.PX_PER_MM * 1e-3,
            drawn.BELT_Y - (v - (drawn.H - 1) / 2) / drawn.PX_PER_MM * 1e-3)
    assert fit.footprint.centroid == pytest.approx(want, abs=5e-5)


@pytest.mark.parametrize("args, kwargs, culprit", [
    ((np.array([np.nan] * len(KIND_NAMES)),), {}, "argument 'scores'"),
    ((np.array([]),), {}, "argument 'scores'"),
    ((np.arange(3.0),), {}, "argument 'scores'"),
    (("abc",), {}, "argument 'scores'"),
    ((-np.ones(len(KIND_NAMES)),), {}, "argument 'scores'"),
    ((np.arange(float(len(KIND_NAMES))), np.nan), {}, "argument 'hole_z2'"),
    ((np.arange(float(len(KIND_NAMES))),), {"min_confidence": np.nan}, "argument 'min_confidence'"),
    ((np.arange(float(len(KIND_NAMES))),), {"min_confidence": 2.0}, "argument 'min_confidence'"),
])
def test_classify_kind_refuses_bad_values(args, kwargs, culprit):
    from cell.errors import VisionError
    with pytest.raises(VisionError, match=culprit):
        classify_kind(*args, **kwargs)


def test_score_fit_refuse_what_is_not_theirs():
    import dataclasses

    from cell.errors import VisionError
    with pytest.raises(VisionError, match="argument 'fp' must be a Footprint"):
        score_kinds("fp")
    fp = dataclasses.replace(describe(_circle(0.015)), length=np.nan)
    with pytest.raises(VisionError, match="argument 'fp'.*finite"):
        score_kinds(fp)
    with pytest.raises(VisionError, match="argument 'blob' must be an Outline"):
        fit_kind("blob", None)
    blob, plane = _drawn_blob(lambda img: cv2.circle(img, drawn.mm(0, 0), drawn.px(10), (200, 200, 195), -1))
    with pytest.raises(VisionError, match="argument 'plane' must be a TablePlane"):
        fit_kind(blob, None)
    with pytest.raises(VisionError, match="argument 'min_confidence'"):
        fit_kind(blob, plane, min_confidence=np.nan)


def test_confidence_halves_from_a_good_fit_to_the_worst_fit():
    """2 ** -((s - 4) / 12) beyond a good fit (score 4), the only kind in reach: 0.794 at 8."""
    scores = np.full(len(KINDS), 30.0)
    scores[0] = 8.0
    assert classify_kind(scores, min_confidence=0.0)[1] == pytest.approx(2 ** (-4 / 12), abs=1e-3)


def test_min_confidence_decides_between_the_kind_and_unknown():
    scores = np.full(len(KINDS), 30.0)
    hex_nut = KIND_NAMES.index("hex_nut")
    scores[hex_nut] = 12.0  # confidence 2 ** (-8 / 12) = 0.63
    assert classify_kind(scores, min_confidence=0.8) == ("unknown", pytest.approx(0.63, abs=0.01))
    assert classify_kind(scores, min_confidence=0.6) == ("hex_nut", pytest.approx(0.63, abs=0.01))
