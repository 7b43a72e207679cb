"""``PartDetector``: one RGB frame and its camera model in, a list of ``Detection`` out.

The detector uses the image, the camera model, the ``[vision]`` settings and the
catalogue's nominal part sizes and finishes; never the simulator. Its steps, each one
module of :mod:`cell.vision.steps`, in the order they run:

1. **foreground** (:mod:`~cell.vision.steps.foreground`): the belt learned from the
   frame itself, or a textbook threshold (``vision.segmentation``);
2. **outlines** (:mod:`~cell.vision.steps.outlines`): one outline per blob, re-thresholded
   at a fraction of its own contrast, shadows dropped;
3. **kind** (:mod:`~cell.vision.steps.footprint`, :mod:`~cell.vision.steps.kind`): the
   outline mapped onto the table plane, free of perspective, and scored per kind;
4. **touching parts** (:mod:`~cell.vision.steps.split`): a blob that fits no kind, fits
   one poorly or holds more than its kind's area is cut (one of no kind too faint against
   the belt, ``vision.faint_contrast``, is dropped uncut);
5. **material** (:mod:`~cell.vision.steps.material`): grain and white-balanced albedo;
6. **pose** (:mod:`~cell.vision.steps.pose`): position and yaw on the table plane.

A part the image border cuts is reported ``partial``, with kind ``unknown`` and no
position (the parts touching it are cut off it, as any touching parts); a blob whose
centre lies off the belt (``vision.belt_y``), or within 4 mm of its edges, is no part.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from cell.camera import CameraModel
from cell.catalogue import KINDS
from cell.errors import VisionError
from cell.vision._checks import check_colour
from cell.vision.settings import VisionSettings
from cell.vision.steps.footprint import TablePlane
from cell.vision.steps.foreground import Foreground, find_foreground
from cell.vision.steps.kind import KindFit, fit_kind, holds_another
from cell.vision.steps.material import MaterialLabel, part_materials
from cell.vision.steps.outlines import Outline, find_outlines, is_faint
from cell.vision.steps.pose import part_pose
from cell.vision.steps.split import Piece, split_blob

__all__ = ["Detection", "PartDetector", "StepTimes"]

_LONGEST = max(k.length for k in KINDS.values())  # m: the longest part
_LONGEST_GROUP = 4 * _LONGEST  # m: a longer blob holds a rail (four discs in a row: 120 mm)
_WELL = 9.0  # a blob whose kind scores under this is one part: no cut is tried
_NEAR_A_KIND = 18.0  # a blob scoring worse than this for every kind is no part
_EDGE = 0.004  # m: a part's centre lies this far inside the belt's edges (half the narrowest is 5.5 mm)
_NARROWEST = 0.0095  # m: a blob narrower than this is a strip, no part (the narrowest is 11 mm)


@dataclass(frozen=True)
class Detection:
    """One part found in a frame.

    ``id`` numbers the detections of one frame (1-based, left to right). ``material`` is
    ``metal``/``plastic``/``unknown`` and ``kind`` a catalogue kind or ``unknown``, each
    with a confidence in 0..1. ``centroid`` is the blob's pixel centroid (u, v);
    ``yaw`` (rad) the part's heading in the world, in [0, 2*pi/symmetry) where
    ``symmetry`` is the kind's rotational order (0 = continuous, yaw then 0).
    ``position`` is (x, y) of the footprint centroid on the world table plane (metres),
    ``None`` when ``partial`` (the part touches the image border); ``size`` is
    (length, width) of the footprint (metres). ``defect`` is always False for now.
    """

    id: int
    material: str
    material_confidence: float
    kind: str
    kind_confidence: float
    centroid: tuple[float, float]
    yaw: float
    symmetry: int
    position: tuple[float, float] | None
    size: tuple[float, float]
    partial: bool
    defect: bool = False

    def to_dict(self) -> dict:
        """Plain JSON-ready dict."""
        out = asdict(self)
        out["centroid"] = list(self.centroid)
        out["position"] = None if self.position is None else list(self.position)
        out["size"] = list(self.size)
        return out


@dataclass(frozen=True)
class StepTimes:
    """Wall time (seconds) of each step of one detection: ``foreground`` (step 1),
    ``outlines`` (2), ``parts`` (3 and 4: kind and touching parts), ``material`` (5) and
    ``pose`` (6, with the detections' assembly)."""

    foreground: float
    outlines: float
    parts: float
    material: float
    pose: float


class PartDetector:
    """Finds, names and locates parts in an RGB frame. See the module docstring.

    ``last_times`` holds the :class:`StepTimes` of the latest :meth:`detect` (None before
    the first)."""

    def __init__(self, settings: VisionSettings | None = None) -> None:
        self.last_times: StepTimes | None = None
        self.settings = settings if settings is not None else VisionSettings()
        if not isinstance(self.settings, VisionSettings):
            raise VisionError(
                f"argument 'settings': expected VisionSettings, got {type(settings).__name__}"
            )

    def detect(self, image: np.ndarray, camera: CameraModel) -> list[Detection]:
        """Detections in ``image`` (uint8 RGB, (H, W, 3)) seen by ``camera``."""
        _check_frame(image, camera)
        st = self.settings
        t0 = time.perf_counter()
        plane = TablePlane(camera, st.plane_z)
        fg = find_foreground(image, st, m_per_px=plane.m_per_px)             # step 1
        t1 = time.perf_counter()
        min_px = st.min_area_mm2 * 1e-6 / plane.m_per_px**2
        blobs = find_outlines(fg, st, min_px=min_px,                         # step 2
                              max_px=_LONGEST_GROUP / plane.m_per_px)
        t2 = time.perf_counter()
        pieces = [p for blob in blobs for p in self._parts(blob, fg, plane)]   # steps 3, 4
        pieces.sort(key=lambda p: p.blob.centroid)
        t3 = time.perf_counter()
        materials = part_materials(image, _own_pixels(image.shape[:2], pieces),  # step 5
                                   [p.blob.pixels for p in pieces], settings=st,
                                   backlit=fg.backlit, impulses=fg.impulses)
        t4 = time.perf_counter()
        out = [_detection(i, p, m)                                              # step 6
               for i, (p, m) in enumerate(zip(pieces, materials, strict=True), 1)]
        self.last_times = StepTimes(t1 - t0, t2 - t1, t3 - t2, t4 - t3, time.perf_counter() - t4)
        return out

    def _parts(self, blob: Outline, fg: Foreground, plane: TablePlane) -> list[Piece]:
        """The part(s) in a blob: itself when a kind fits it well; its pieces when it is
        touching parts; none when it is not a part (its centre off the belt, see
        ``vision.belt_y``, or within ``_EDGE`` of its edges). A blob at the image border:
        see :meth:`_at_border`."""
        st = self.settings
        (_, y), = plane.points(np.array([blob.centroid]), 0.0)
        if not st.belt_y[0] + _EDGE <= y <= st.belt_y[1] - _EDGE:
            return []  # a shadow on the table, a rail, light along the edge: no part's centre
        fit = fit_kind(blob, plane, min_confidence=st.min_kind_confidence)
        if blob.partial:
            return self._at_border(blob, fit, fg, plane)
        if fit.kind != "unknown" and fit.score < _WELL and not holds_another(fit):
            return [Piece(blob, fit)]
        if fit.kind == "unknown" and is_faint(blob.pixels, fg, st.faint_contrast):
            return []  # belt texture or noise at the threshold: no parts to search for
        if st.split_touching:
            pieces = split_blob(blob, fit, foreground=fg, plane=plane,
                                min_confidence=st.min_kind_confidence,
                                faint_contrast=st.faint_contrast)
            if pieces:
                return pieces
        fp = fit.footprint
        if (fit.score > _NEAR_A_KIND or plane.area_mm2(blob) > st.max_area_mm2
                or fp.length > 1.3 * _LONGEST or fp.width < _NARROWEST):
            return []  # like no kind at all, larger than two parts, or a strip: no part
        return [Piece(blob, fit)]  # one part (``unknown`` when it fits its kind too poorly)

    def _at_border(self, blob: Outline, fit: KindFit, fg: Foreground, plane: TablePlane
                   ) -> list[Piece]:
        """A blob at the image border is one part of kind ``unknown`` (:func:`_partial`),
        unless it holds parts touching the one the border cuts: then those are parts of
        their own (the search for touching parts leaves the piece at the border out of a
        cut's score)."""
        st = self.settings
        pieces = []
        if st.split_touching:
            pieces = split_blob(blob, fit, foreground=fg, plane=plane,
                                min_confidence=st.min_kind_confidence,
                                faint_contrast=st.faint_contrast)
        if not pieces:
            return _partial(blob, fit, plane, st)
        return [q for p in pieces
                for q in (_partial(p.blob, p.fit, plane, st) if p.blob.partial else [p])]


def _own_pixels(shape: tuple[int, int], pieces: list[Piece]) -> np.ndarray:
    """uint8 (H, W): 255 on every piece's own pixels (the rest is belt, for the material
    step's white balance)."""
    out = np.zeros(shape, np.uint8)
    for p in pieces:
        px = p.blob.pixels
        h, w = px.mask.shape
        out[px.y0:px.y0 + h, px.x0:px.x0 + w] |= px.mask
    return out


def _check_frame(image: np.ndarray, camera: CameraModel) -> None:
    check_colour("image", image)
    if not isinstance(camera, CameraModel):
        raise VisionError(f"argument 'camera': expected CameraModel, got {type(camera).__name__}")
    h, w = image.shape[:2]
    if (camera.width, camera.height) != (w, h):
        raise VisionError(f"argument 'camera': model is {camera.width}x{camera.height}, "
                          f"image is {w}x{h}")
    if h < 16 or w < 16:
        raise VisionError(f"argument 'image': too small ({w}x{h}), need at least 16x16")


def _partial(blob: Outline, fit: KindFit, plane: TablePlane, st: VisionSettings
             ) -> list[Piece]:
    """A blob at the image border (``fit`` its kind fit), as a part of kind ``unknown``,
    unless it is no part (a rail, a belt edge, the table beyond) or a sliver."""
    fp = fit.footprint
    if (plane.area_mm2(blob) > st.max_area_mm2 or fp.length > 1.3 * _LONGEST
            or fp.width < st.partial_min_width):
        return []
    return [Piece(blob, KindFit("unknown", 0.0, fit.score, fp))]


def _detection(i: int, piece: Piece, material: MaterialLabel) -> Detection:
    fp, kind = piece.fit.footprint, piece.fit.kind
    pose = part_pose(fp.outline, centroid=fp.centroid, rect_angle=fp.rect_angle,           # step 6
                     kind=kind if not piece.blob.partial else "unknown", cut=piece.cut)
    return Detection(
        id=i,
        material=material.material,
        material_confidence=round(float(material.confidence), 4),
        kind=kind,
        kind_confidence=round(float(piece.fit.confidence), 4),
        centroid=(float(piece.blob.centroid[0]), float(piece.blob.centroid[1])),
        yaw=pose.yaw,
        symmetry=KINDS[kind].symmetry if kind in KINDS else 0,
        position=None if piece.blob.partial else pose.position,
        size=(fp.length, fp.width),
        partial=piece.blob.partial,
    )
