"""Template matching: SSD, SAD and NCC score maps, best match, two-template decision.

Score maps have shape (H - h + 1, W - w + 1); entry (y, x) scores the template placed
with its top-left corner at pixel (x, y). SSD and SAD are distances (best = minimum);
NCC is the zero-mean normalised cross-correlation in [-1, 1] (best = maximum), which
is unchanged by a brightness/contrast change ``I' = a I + b`` (a > 0) of the image
window, where SSD and SAD are not.

References: Gonzalez & Woods, *Digital Image Processing*, 4th ed., 12.3 (matching by
correlation); J. P. Lewis, "Fast normalized cross-correlation", Vision Interface 1995;
OpenCV ``cv2.matchTemplate`` (TM_SQDIFF, TM_CCOEFF_NORMED). SAD has no OpenCV
method: :func:`match_sad` is written here, vectorised over the whole map.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_choice, check_finite, check_gray, check_int, check_range

__all__ = [
    "Match",
    "TemplateDecision",
    "best_match",
    "match_ncc",
    "match_sad",
    "match_ssd",
    "two_template_decision",
]

_DTYPES = (np.uint8, np.float32)
METHODS = ("ssd", "sad", "ncc")
MAX_SAD_WORK = 2**32  # h * w * (H-h+1) * (W-w+1) pixel differences: a few seconds


def _pair(image: np.ndarray, template: np.ndarray, name: str = "template"):
    """Both checked: grey, uint8 or float32, finite (one NaN pixel would make every SSD
    score 0, a perfect match everywhere), the template no larger than the image; both
    uint8 as they are (``cv2.matchTemplate`` then scores an exact match 0; converted to
    float32 first, its sums of squares cancel to tens of grey levels^2 off), else both
    float32."""
    image = check_finite("image", check_gray("image", image, dtypes=_DTYPES))
    template = check_finite(name, check_gray(name, template, dtypes=_DTYPES))
    if template.shape[0] > image.shape[0] or template.shape[1] > image.shape[1]:
        raise VisionError(
            f"argument '{name}': shape {template.shape} is larger than the image's {image.shape}"
        )
    if image.dtype == template.dtype == np.uint8:
        return image, template
    return image.astype(np.float32, copy=False), template.astype(np.float32, copy=False)


def match_ssd(image: np.ndarray, template: np.ndarray) -> np.ndarray:
    """Sum of squared differences ``sum (I(x+u, y+v) - T(u, v))^2`` per placement.

    image, template : uint8 or float32 (H, W), (h, w), finite. Returns float32
    (H-h+1, W-w+1), grey levels squared. Wraps ``cv2.matchTemplate(..., cv2.TM_SQDIFF)``,
    which sums in floating point: a score is exact to about 1e-7 of the window's sum of
    squares (an exact match of uint8 images scores 0).
    """
    img, tpl = _pair(image, template)
    return cv2.matchTemplate(img, tpl, cv2.TM_SQDIFF)


def match_sad(image: np.ndarray, template: np.ndarray) -> np.ndarray:
    """Sum of absolute differences ``sum |I(x+u, y+v) - T(u, v)|`` per placement.

    Hand-written (OpenCV has no SAD mode): the Python loop runs over the ``h * w``
    template pixels, and each step adds ``|I shifted - T(u, v)|`` for every placement
    at once with in-place numpy operations on (H-h+1) x (W-w+1) float32 buffers
    (about 9 ms for a 24x24 template on a 208x160 image; cost grows as h*w*H*W, so
    ``h * w * (H-h+1) * (W-w+1)`` is limited to 2**32, a few seconds).

    image, template : uint8 or float32 (H, W), (h, w), finite. Returns float32
    (H-h+1, W-w+1), grey levels.
    """
    img, tpl = (a.astype(np.float32, copy=False) for a in _pair(image, template))
    h, w = tpl.shape
    rows, cols = img.shape[0] - h + 1, img.shape[1] - w + 1
    if h * w * rows * cols > MAX_SAD_WORK:
        raise VisionError(
            f"argument 'template': a {h}x{w} template over {rows}x{cols} placements is "
            f"{h * w * rows * cols} pixel differences, more than 2**32 (use match_ssd)"
        )
    out = np.zeros((rows, cols), np.float32)
    tmp = np.empty_like(out)
    for dy in range(h):
        for dx in range(w):
            np.subtract(img[dy : dy + rows, dx : dx + cols], tpl[dy, dx], out=tmp)
            np.abs(tmp, out=tmp)
            out += tmp
    return out


def match_ncc(image: np.ndarray, template: np.ndarray) -> np.ndarray:
    """Zero-mean normalised cross-correlation per placement, in [-1, 1].

    ``sum (I' T') / sqrt(sum I'^2 sum T'^2)`` with ``I'``, ``T'`` the window and the
    template minus their means. A flat window (zero variance) scores 0.

    image, template : uint8 or float32 (H, W), (h, w), finite. Returns float32
    (H-h+1, W-w+1). Wraps ``cv2.matchTemplate(..., cv2.TM_CCOEFF_NORMED)``.
    """
    img, tpl = _pair(image, template)
    return _ncc(img, tpl, "template")


def _ncc(img: np.ndarray, tpl: np.ndarray, name: str) -> np.ndarray:
    if float(tpl.std()) == 0.0:
        raise VisionError(f"argument '{name}': a flat template has no correlation")
    out = cv2.matchTemplate(img, tpl, cv2.TM_CCOEFF_NORMED)
    return np.nan_to_num(np.clip(out, -1.0, 1.0), nan=0.0, posinf=0.0, neginf=0.0)


@dataclass(frozen=True)
class Match:
    """Best placement: ``x``, ``y`` (top-left, pixels), ``centre`` (x, y) of the
    matched window (pixels), ``score`` (the map's value there)."""

    x: int
    y: int
    centre: tuple[float, float]
    score: float


def best_match(scores: np.ndarray, template_shape: tuple[int, int], *, method: str) -> Match:
    """The best placement in a score map: minimum for "ssd"/"sad", maximum for "ncc".

    scores : float32 (H-h+1, W-w+1), finite, from :func:`match_ssd`, :func:`match_sad`
    or :func:`match_ncc`. template_shape : the template's (h, w), integers from 1 to
    2**31 - 1 (pixels; they place the centre). method : "ssd", "sad" or "ncc".
    """
    check_choice("method", method, METHODS)
    scores = check_finite("scores", check_gray("scores", scores, dtypes=(np.float32,)))
    if not isinstance(template_shape, tuple | list) or len(template_shape) != 2:
        raise VisionError(f"argument 'template_shape': expected (h, w), got {template_shape!r:.40}")
    h, w = (check_int("template_shape", v, 1, 2**31 - 1) for v in template_shape)
    idx = np.argmax(scores) if method == "ncc" else np.argmin(scores)
    y, x = np.unravel_index(idx, scores.shape)
    return Match(int(x), int(y), (x + (w - 1) / 2, y + (h - 1) / 2), float(scores[y, x]))


@dataclass(frozen=True)
class TemplateDecision:
    """Outcome of :func:`two_template_decision`: ``label`` "A", "B" or "none";
    best NCC ``score_a``, ``score_b`` and where each peaked."""

    label: str
    score_a: float
    score_b: float
    match_a: Match
    match_b: Match


def two_template_decision(
    image: np.ndarray,
    template_a: np.ndarray,
    template_b: np.ndarray,
    *,
    threshold: float = 0.7,
    margin: float = 0.05,
) -> TemplateDecision:
    """Decide whether ``image`` shows part A, part B, or neither.

    Correlate both templates (NCC); the one with the higher peak wins if that peak
    reaches ``threshold`` and beats the other by at least ``margin``; otherwise
    "none" (no part, or too close to call). The syllabus' decision rule for
    template-based sorting.

    Parameters
    ----------
    image, template_a, template_b : uint8 or float32 grey images, finite.
    threshold : minimum NCC peak to accept a part, 0..1.
    margin : minimum lead of the winner over the other template, NCC units, 0..2.
    """
    check_range("threshold", threshold, 0.0, 1.0)
    check_range("margin", margin, 0.0, 2.0)
    ma = _ncc_peak(image, template_a, "template_a")
    mb = _ncc_peak(image, template_b, "template_b")
    best, other, label = (ma, mb, "A") if ma.score >= mb.score else (mb, ma, "B")
    if best.score < threshold or best.score - other.score < margin:
        label = "none"
    return TemplateDecision(label, ma.score, mb.score, ma, mb)


def _ncc_peak(image: np.ndarray, template: np.ndarray, name: str) -> Match:
    img, tpl = _pair(image, template, name)
    return best_match(_ncc(img, tpl, name), tpl.shape, method="ncc")
