"""Pose step: a part's position and yaw on the table plane from its footprint's outline.

The yaw is measured modulo the kind's rotational symmetry n
(``cell.catalogue.KINDS[kind].symmetry``), in [0, 2*pi/n):

* **Nuts** (hex nut n = 6, yaw 0: a corner on +x; square nut n = 4, yaw 0: flats facing
  +x): the direction of the flats from the n-th circular harmonic of the outline's chord
  directions. Each chord ``p[k + 5] - p[k]`` (cyclic) has direction psi_k and length l_k;
  the flats dominate ``m = sum_k l_k exp(i n psi_k)`` and their normals point at
  ``arg(m) / n + pi/2``. A chord's direction does not depend on how far the outline lies
  from the centre, so a dilated or slightly perspective-stretched outline gives the same
  angle (Mardia & Jupp, *Directional Statistics*, 2000, ch. 3: mean direction of n-fold
  axial data). The mean is then re-estimated twice with each chord's weight also scaled by
  a von Mises kernel ``exp(kappa * (cos(n * psi_k - arg m) - 1))``, an iteratively
  reweighted (M-estimator) mean: chords across corners and along ragged stretches of a
  noisy outline count less (kappa: hex nut 1, square nut 2). That direction is then refined
  by fitting the nut's shape to the outline points themselves: a convex n-gon whose flats
  face ``phi + 2*pi*k/n``, each flat at its own distance ``a_k`` from the centroid, each
  point's residual its signed distance beyond the polygon's nearest flat line
  (``max_k (n_k . q - a_k)``), fitted by robust least squares (``scipy.optimize.least_squares``,
  Huber loss at 0.2 mm: the outline's noise; farther points, a bite or a bump, count
  linearly; Huber, *Robust Statistics*, 1981). A chord spans 6 points (5 steps) of one flat, the fit
  all of them: on outlines jittered by 0.1 mm the median error falls from 0.17 to 0.15 deg
  (hex nut; square 0.14 to 0.10), and a bite out of one flat (a ramp 0.8 mm deep, the
  neighbour's notch) turns it by 0.02 deg, not 0.46. A flat moved parallel as a whole (a
  dilated outline, a shadow's remnant) does not pull the angle, its offset being free; a
  flat broken into two offsets does (0.4 mm over half a flat: 0.66 deg, the chords 0.17).
  On the bench's rendered frames the fit brings the presets' yaw p95 down by a seventh on
  average (``cell bench vision``, four sets: 1.16 to 1.00 deg, four of 32 presets rising
  by 0.13 deg at most; four sets used for no tuning: 1.14 to 0.99, four rising by 0.06 at
  most).
  It costs about 0.9 ms per nut. The outline's points marked ``cut`` lie on a straight cut
  that separated the part from one it touched (or two, for the middle part of a row), not
  on an edge: those points and ``_CUT_GUARD`` points either side (the contact's notch) are
  left out of both, chords and fit.
* **L bracket** (n = 1; yaw 0: outer corner at -x, -y, long leg along +x, as
  ``cell.sim.parts`` builds it): all its edges run at multiples of 90 degrees. The
  minimum-area rectangle's long side follows a clean outline closely but turns with a bite
  or a shadow on one side; the 4-fold chord mean above (kappa 2) does not, so where the two
  disagree by more than 2 degrees the chords' angle is taken (a cut's chords left out, as
  the nuts'). The centroid sits near the
  outer corner, so of the axis' two senses the yaw is the one in which the outline reaches
  farther from the centroid (the long leg's tip).
* **Bolt** (n = 2): the principal axis of the outline's second moments,
  ``0.5 * atan2(2 mu11, mu20 - mu02)`` (Gonzalez & Woods, *Digital Image Processing*,
  ch. 11), from ``cv2.moments`` (Green's theorem) on the outline as a float32 contour in
  millimetres around its first point (float32 keeps its precision there).
* Any other kind with n > 0: the rectangle's long side; n = 0 (washer, disc) or an
  ``"unknown"`` part: 0.

The position is the footprint's area centroid, except a bolt's: the area centroid moves
with its hex head's roll (10 or 11.5 mm wide), its ends do not, so the reference point is on
the rectangle's long axis, 1.4 mm from the middle of the outline's two extremes along it
towards the head (the end whose 4 mm strip reaches wider off the axis): the body origin of
``cell.sim.parts``, whose modelled ends lie at -20.5 and +23.5 mm (1.5 mm from their
middle; the rendered outline's ends put it 1.4 mm from theirs: over 287 bolts the bias
along the axis is a median -0.009 mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import maximum_filter1d
from scipy.optimize import least_squares

from cell.catalogue import KINDS
from cell.errors import VisionError
from cell.vision._checks import check_range

__all__ = ["Pose", "kind_yaw", "part_pose"]

_STEP = 5  # chord span, outline points
_ITERATIONS = 2  # von Mises reweightings of the harmonic mean
_KAPPA = {"hex_nut": 1.0, "square_nut": 2.0}  # the nuts' von Mises concentration
_BRACKET_KAPPA = 2.0
_CUT_GUARD = 6  # outline points either side of a cut left out of the nuts' flats
_FLAT_NOISE = 0.2  # mm: the Huber scale of the nuts' flat fit (an outline point's noise)
_FLAT_TOL = 1e-4  # the fit's relative tolerances: 0.005 deg, 1 um (9 -> 6 evaluations)
_L_TURN = math.radians(2.0)  # bracket: chords vs rectangle disagreement that picks the chords
_BOLT_STRIP = 0.004  # m: the strip at each end of a bolt whose width tells the head
_BOLT_END_OFFSET = 0.0014  # m: body origin from the middle of the bolt's ends, towards the head


@dataclass(frozen=True)
class Pose:
    """A part's pose on the table plane: ``position`` (x, y) metres, world frame; ``yaw``
    radians in [0, 2*pi/symmetry), 0 when symmetry is 0."""

    position: tuple[float, float]
    yaw: float


def part_pose(outline: np.ndarray, *, centroid: tuple[float, float], rect_angle: float, kind: str,
              cut: np.ndarray | None = None) -> Pose:
    """The pose of a part of ``kind`` from its footprint (see the module's docstring).

    outline: (N, 2) float, the footprint's outer boundary on the table plane (metres);
    centroid: the footprint's area centroid (m); rect_angle: direction of the minimum-area
    rectangle's long side (rad); kind: a catalogue kind name (``cell.catalogue.KINDS``) or
    ``"unknown"`` (then yaw 0, position the centroid); cut: (N,) bool, the outline's points
    that lie on a straight cut from a touching part (left out of the edges a nut's or an L
    bracket's yaw reads), or None.
    """
    p, c, on_cut = _checked("part_pose", outline, centroid, kind, cut)
    yaw = _yaw(p, c, float(rect_angle), kind, on_cut)
    position = _bolt_point(p, c, float(rect_angle)) if kind == "bolt" else c
    return Pose(position=(float(position[0]), float(position[1])), yaw=yaw)


def kind_yaw(outline: np.ndarray, *, centroid: tuple[float, float], rect_angle: float, kind: str,
             cut: np.ndarray | None = None) -> float:
    """The yaw (rad, in [0, 2*pi/symmetry), 0 for symmetry 0 or ``"unknown"``) of
    :func:`part_pose`, alone; ``rect_angle`` a finite number (rad)."""
    p, c, on_cut = _checked("kind_yaw", outline, centroid, kind, cut)
    rect_angle = check_range("rect_angle", rect_angle, -math.inf, math.inf)
    if not math.isfinite(rect_angle):
        raise VisionError(f"kind_yaw: argument 'rect_angle': expected a finite angle (rad), "
                          f"got {rect_angle!r}")
    return _yaw(p, c, rect_angle, kind, on_cut)


def _checked(where: str, outline, centroid, kind: str, cut
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The outline (N, 2) and centroid (2,) as float64 arrays and the cut (N,) bool (all
    False for None), or a VisionError naming the function ``where`` and the argument that is
    wrong."""
    p = np.asarray(outline, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 3:
        raise VisionError(f"{where}: outline must be (N>=3, 2), got shape {p.shape}")
    if not np.isfinite(p).all():
        raise VisionError(f"{where}: outline has non-finite points")
    c = np.asarray(centroid, dtype=np.float64)
    if c.shape != (2,) or not np.isfinite(c).all():
        raise VisionError(f"{where}: centroid must be two finite numbers, got {centroid!r}")
    if not isinstance(kind, str) or (kind != "unknown" and kind not in KINDS):
        raise VisionError(f"{where}: argument 'kind': {kind!r} is not a kind (valid: "
                          f"{', '.join(KINDS)}, unknown)")
    if cut is None:
        return p, c, np.zeros(len(p), bool)
    if not isinstance(cut, np.ndarray) or cut.dtype != bool or cut.shape != (len(p),):
        got = f"{cut.dtype} {cut.shape}" if isinstance(cut, np.ndarray) else type(cut).__name__
        raise VisionError(f"{where}: cut must be None or a bool array of the outline's "
                          f"length ({len(p)},), got {got}")
    return p, c, cut


def _yaw(p: np.ndarray, c: np.ndarray, rect_angle: float, kind: str, cut: np.ndarray) -> float:
    """Yaw of a checked outline for its kind, folded into [0, 2*pi/n)."""
    n = KINDS[kind].symmetry if kind in KINDS else 0
    if n == 0:
        return 0.0
    out = _cut_and_guard(cut) if cut.any() else cut  # (no cut: nothing to widen)
    skip = _chords_into(out) if out.any() else None
    if kind in _KAPPA:  # the nuts: their flats' normals; a hex nut's yaw is a corner's
        first = _flat_angle(p, n, kappa=_KAPPA[kind], skip=skip)
        yaw = _fitted_flats(p, c, n, first, ~out)
        yaw -= math.pi / 6 if kind == "hex_nut" else 0.0
    elif kind == "l_bracket":
        yaw = _bracket_yaw(p, c, rect_angle, skip=skip)
    elif kind == "bolt":
        yaw = _second_moment_angle(p)
    else:
        yaw = rect_angle
    period = 2 * math.pi / n
    yaw %= period
    return 0.0 if yaw >= period else yaw  # (a tiny negative angle rounds up to the period)


def _cut_and_guard(cut: np.ndarray) -> np.ndarray:
    """Mask (N,) of the outline points a yaw leaves out: those on a cut (``cut``, bool) and
    ``_CUT_GUARD`` points either side of each, cyclically (``scipy.ndimage.maximum_filter1d``),
    while at least half the outline is kept; else the cut's points alone, or none when
    they are more than half."""
    half = len(cut) // 2
    out = maximum_filter1d(cut, size=2 * _CUT_GUARD + 1, mode="wrap")
    if np.count_nonzero(out) <= half:
        return out
    return cut if np.count_nonzero(cut) <= half else np.zeros_like(cut)


def _chords_into(out: np.ndarray) -> np.ndarray:
    """Mask (N,) of the chords ``p[k] -> p[k + _STEP]`` (cyclic) that span a point of ``out``:
    a window of ``_STEP + 1`` points starting at k."""
    return maximum_filter1d(out, size=_STEP + 1, mode="wrap", origin=-((_STEP + 1) // 2))


def _fitted_flats(p: np.ndarray, c: np.ndarray, n: int, first: float, keep: np.ndarray) -> float:
    """Direction (rad) of the flats' normals of an n-fold outline ``p`` (N, 2, metres) around
    its centroid ``c``, refined from ``first``: the n-gon with free flat offsets fitted to
    the points ``keep`` by robust least squares (module docstring). ``first`` when fewer
    than two points per flat are kept."""
    q = (p[keep] - c) * 1e3  # mm, from the centroid
    if len(q) < 2 * n:
        return first
    turns = np.arange(n) * (2 * math.pi / n)

    def beyond(x: np.ndarray) -> np.ndarray:  # (N, n): how far each point lies beyond each flat
        a = x[0] + turns
        return q[:, :1] * np.cos(a) + q[:, 1:] * np.sin(a) - x[1:]

    def jacobian(x: np.ndarray) -> np.ndarray:  # of beyond(x).max(axis=1): its flat's row
        k = beyond(x).argmax(axis=1)
        a = x[0] + turns[k]
        jac = np.zeros((len(q), n + 1))
        jac[:, 0] = q[:, 1] * np.cos(a) - q[:, 0] * np.sin(a)
        jac[np.arange(len(q)), 1 + k] = -1.0
        return jac

    start = np.concatenate([[first], np.zeros(n)])
    start[1:] = np.median(beyond(start).max(axis=1))  # every flat at the median distance
    fit = least_squares(lambda x: beyond(x).max(axis=1), start, jac=jacobian, loss="huber",
                        f_scale=_FLAT_NOISE, xtol=_FLAT_TOL, ftol=_FLAT_TOL)
    return float(fit.x[0])


def _flat_angle(p: np.ndarray, n: int, *, kappa: float, skip: np.ndarray | None = None) -> float:
    """Direction (rad) of the flats' normals of an n-fold outline ``p`` (N, 2), mod 2*pi/n:
    the reweighted n-th circular harmonic of its chord directions (module docstring); the
    chords marked in ``skip`` left out."""
    chord = np.roll(p, -_STEP, axis=0) - p
    length = np.hypot(chord[:, 0], chord[:, 1])
    if skip is not None:
        length[skip] = 0.0
    e = np.exp(1j * n * np.arctan2(chord[:, 1], chord[:, 0]))  # exp(i n psi_k)
    mean = np.sum(length * e)
    for _ in range(_ITERATIONS):
        unit = np.conj(mean) / max(abs(mean), 1e-300)
        mean = np.sum(length * np.exp(kappa * ((e * unit).real - 1.0)) * e)
    return math.atan2(mean.imag, mean.real) / n + math.pi / 2


def _bracket_yaw(p: np.ndarray, c: np.ndarray, rect_angle: float, *,
                 skip: np.ndarray | None = None) -> float:
    """Yaw of an L bracket: direction of its long leg, seen from the outer corner; the
    chords marked in ``skip`` (a cut) left out of the chords' angle."""
    a = rect_angle
    off = (_flat_angle(p, 4, kappa=_BRACKET_KAPPA, skip=skip) - a + math.pi / 4) % (math.pi / 2) - math.pi / 4
    if abs(off) > _L_TURN:
        a += off
    u = np.array([math.cos(a), math.sin(a)])
    s = (p - c) @ u
    sense = 1.0 if s.max() > -s.min() else -1.0
    return math.atan2(sense * u[1], sense * u[0])


def _second_moment_angle(p: np.ndarray) -> float:
    """Direction (rad) of the principal axis of the polygon ``p`` (N, 2, metres), from
    ``cv2.moments`` of it as a float32 contour in mm around its first point."""
    m = cv2.moments(((p - p[0]) * 1e3).astype(np.float32))
    return 0.5 * math.atan2(2 * m["mu11"], m["mu20"] - m["mu02"])


def _bolt_point(p: np.ndarray, c: np.ndarray, rect_angle: float) -> np.ndarray:
    """(x, y) of a bolt's reference point: on the rectangle's long axis, 1.4 mm from the
    middle of the outline's two extremes along it, towards the wider end (the head)."""
    axis = np.array([math.cos(rect_angle), math.sin(rect_angle)])
    rel = p - c
    s = rel @ axis
    t = np.abs(rel @ np.array([-axis[1], axis[0]]))
    s_max, s_min = s.max(), s.min()
    w_max = t[s > s_max - _BOLT_STRIP].max()
    w_min = t[s < s_min + _BOLT_STRIP].max()
    to_head = 1.0 if w_max > w_min else -1.0
    mid = 0.5 * (s_max + s_min) + to_head * _BOLT_END_OFFSET
    return c + mid * axis
