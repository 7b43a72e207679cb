"""``PartDetector``: one RGB frame and its camera model in, a list of ``Detection`` out.

What the detector uses: the image, the camera model (intrinsics, distortion, pose), the
``VisionSettings`` (including the belt's nominal reflectance, the white-balance reference)
and the catalogue's nominal part geometry and finishes. It never reads the simulator.
Its background model is learned from the frame itself (a median filter much wider than
any part over a 1/8-scale copy), so light gradients, spot lights and colour temperature
need no calibration image. No second image is used.

Pipeline (each step a textbook technique, each in its own module):
1. background estimate and per-pixel colour difference (largest channel) at half scale;
   a noisy frame (MAD > 2 grey levels) is box-filtered first; noise-adaptive threshold
   (median + k * MAD, with a floor), or fixed or Otsu; an opening removes specks; a
   frame whose background is a bright light table is taken as back-lit
   (:mod:`cell.vision._segment`);
2. contours with holes; every blob is refined at full scale in its own box, all boxes
   at once on one mosaic (:mod:`cell.vision._mosaic`): re-thresholded at a fraction
   (``edge_level``) of its own contrast, shadow pixels (darker than the background by
   one factor in all channels) dropped;
3. the outline is mapped onto the table plane: a contour point whose outward normal faces
   away from the camera's nadir is a top edge, the others bottom edges (a prism seen
   off-axis shows a wall), so the footprint is free of perspective; the kind is chosen
   on a mid-height footprint and the outline mapped again only for the best kind(s);
   every blob of the frame in one compiled pass (:mod:`cell.vision._footprint`,
   :mod:`cell.vision._kindfit`, :mod:`cell.vision._polygons`, :mod:`cell.vision.kind`);
4. a blob that fits no kind (or one poorly) is cut into touching parts: straight cuts
   between convexity defects made on the outline itself, then distance-transform cores,
   recursively, within a budget of cuts, and last a cut along its colours (two finishes:
   :mod:`cell.vision._colourcut`) (:mod:`cell.vision._split`); one that fits no
   kind and is faint (the brightest tenth of it within ``faint_contrast`` thresholds of the
   belt: belt texture or noise) is dropped without a search;
5. material from grain and white-balanced albedo, every part of the frame at once
   (:mod:`cell.vision._part_material`, :mod:`cell.vision.material`); yaw per kind modulo
   its symmetry (a cut between touching parts is not an edge and does not count);
   position the footprint centroid on the table plane (for a bolt, a point fixed
   relative to its two ends; :mod:`cell.vision._pose`). A blob at the image border is
   reported ``partial`` with kind ``unknown`` and no position.
"""

from __future__ import annotations

import math
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from cell.camera import CameraModel
from cell.catalogue import KINDS
from cell.errors import VisionError
from cell.vision._blob import Blob
from cell.vision._centroid import blob_centroid
from cell.vision._checks import check_colour
from cell.vision._footprint import _MID, Fit, Footprints, Geometry, fit_kinds
from cell.vision._footprint import warm_up as _warm_up
from cell.vision._part_material import part_materials
from cell.vision._part_material import warm_up as _warm_up_material
from cell.vision._pose import RECTANGLE, detection_poses
from cell.vision._segment import FrameView, background, find_blobs, foreground
from cell.vision._segment import warm_up as _warm_up_segment
from cell.vision._segment_kernel import upper_decile
from cell.vision._split import split_blob
from cell.vision._split import warm_up as _warm_up_split
from cell.vision.kind import YAW_CODES, footprint, footprint_yaw
from cell.vision.settings import VisionSettings

__all__ = ["Detection", "PartDetector"]

_LONGEST = max(k.length for k in KINDS.values())  # m: the longest part


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


class PartDetector:
    """Finds, names and locates parts in an RGB frame. See the module docstring."""

    def __init__(self, settings: VisionSettings | None = None) -> None:
        self.settings = settings if settings is not None else VisionSettings()
        if not isinstance(self.settings, VisionSettings):
            raise VisionError(
                f"argument 'settings': expected VisionSettings, got {type(settings).__name__}"
            )
        _warm_up_kernels(self)

    def detect(self, image: np.ndarray, camera: CameraModel) -> list[Detection]:
        """Detections in ``image`` (uint8 RGB, (H, W, 3)) seen by ``camera``."""
        check_colour("image", image)
        if not isinstance(camera, CameraModel):
            raise VisionError(f"argument 'camera': expected CameraModel, got {type(camera).__name__}")
        h, w = image.shape[:2]
        if (camera.width, camera.height) != (w, h):
            raise VisionError(
                f"argument 'camera': model is {camera.width}x{camera.height}, image is {w}x{h}"
            )
        if h < 16 or w < 16:
            raise VisionError(f"argument 'image': too small ({w}x{h}), need at least 16x16")
        st = self.settings
        img = np.ascontiguousarray(image)
        bg_small, backlit = background(img, st)
        dmax, mask, t, smooth = foreground(img, bg_small, st)
        geo = self._geometry(camera)
        view = FrameView(img, bg_small, dmax, mask, t, smooth, backlit, geo, st,
                         max_px=int(2.5 * _LONGEST / geo.m_per_px),
                         min_px=st.min_area_mm2 * 1e-6 / geo.m_per_px**2)
        found: list[tuple[Blob, str, float, Fit]] = []
        blobs = [b for b in find_blobs(view) if geo.area_mm2(b) >= st.min_area_mm2]
        whole = [b for b in blobs if not b.partial]
        for blob, fitted in zip(whole, fit_kinds(whole, geo, st.min_kind_confidence), strict=True):
            found.extend(self._interpret(blob, fitted, view))
        found.extend(self._partials([b for b in blobs if b.partial], geo))
        found.sort(key=lambda f: (f[3].centroid_px[0], f[3].centroid_px[1]))
        materials = part_materials(view, [f[0] for f in found])
        return _make_detections(found, materials)

    def _geometry(self, camera: CameraModel) -> Geometry:
        """The camera's ray geometry, kept while frames come from an equal camera model."""
        key = b"".join(np.asarray(a, dtype=np.float64).tobytes()
                       for a in (camera.K, camera.dist, camera.T_world_camera))
        cached = getattr(self, "_geo", None)
        if cached is not None and cached[0] == key:
            return cached[1]
        geo = Geometry(camera, self.settings.plane_z)
        self._geo = (key, geo)
        return geo

    def _interpret(self, blob: Blob, fitted: tuple[str, float, float, Fit],
                   view: FrameView) -> list[tuple[Blob, str, float, Fit]]:
        """The part(s) in one blob, given its best kind (``fitted``): one when a kind fits
        it, several when it splits into touching parts, none when it is not a part."""
        st, geo = self.settings, view.geo
        kind, conf, fit, res = fitted
        if kind != "unknown" and fit < 9.0:
            res.centroid_px = blob_centroid(blob)
            return [(blob, kind, conf, res)]
        if kind == "unknown" and st.faint_contrast > 0 and blob.roi is not None:
            x0, y0, own = blob.roi
            if upper_decile(view.dmax, own, x0, y0) < st.faint_contrast * view.threshold:
                return []  # belt texture or noise at the threshold: no parts to search for
        area_mm2 = geo.area_mm2(blob)
        if st.split_touching and area_mm2 > 1.5 * st.min_area_mm2:
            pieces = split_blob(blob, view, whole_fit=fit if kind != "unknown" else math.inf)
            if pieces:
                return pieces
        if kind == "unknown" or area_mm2 > st.max_area_mm2:
            return []
        res.centroid_px = blob_centroid(blob)
        return [(blob, kind, conf, res)]

    def _partials(self, blobs: list[Blob], geo: Geometry) -> list[tuple[Blob, str, float, Fit]]:
        """Blobs at the image border: parts of kind ``unknown`` (no position), except what
        is not a part (a rail, a belt edge, the table beyond) and slivers."""
        if not blobs:
            return []
        st = self.settings
        mid = Footprints(geo, blobs, _MID)
        out = []
        for i, blob in enumerate(blobs):
            if (geo.area_mm2(blob) > st.max_area_mm2 or mid.d.length[i] > 1.3 * _LONGEST
                    or mid.d.width[i] < st.partial_min_width):
                continue
            res = mid.fit(i)
            res.centroid_px = blob_centroid(blob)
            out.append((blob, "unknown", 0.0, res))
        return out


def _make_detections(found: list[tuple[Blob, str, float, Fit]],
                     materials: list[tuple[str, float]]) -> list[Detection]:
    """The detections of the parts ``found`` (blob, kind, confidence, Fit) with their
    ``materials``, numbered from 1: each yaw from its footprint's outline, each position
    the footprint's centroid (a bolt's: :func:`~cell.vision._pose.bolt_point`), read from
    the ``Fit``'s descriptor row without building its ``Footprint``; all poses in one
    compiled call (:func:`~cell.vision._pose.detection_poses`)."""
    if not found:
        return []
    rows, outlines, sizes = [], [], [0]
    for blob, kind, _, res in found:
        _, _, cx, cy, length, width, angle = res.row[:7].tolist()
        known = kind in KINDS
        rows.append((cx, cy, angle, YAW_CODES.get(kind, RECTANGLE) if known else -1,
                     KINDS[kind].symmetry if known else 0, res.cut,
                     kind == "bolt" and not blob.partial, length, width))
        outlines.append(res.outline)
        sizes.append(sizes[-1] + len(outlines[-1]))
    table = np.array(rows)
    yaw, xy = np.empty(len(found)), np.empty((len(found), 2))
    detection_poses(np.concatenate(outlines), np.array(sizes), table, yaw, xy)
    out = []
    for i, ((blob, kind, conf, res), (material, m_conf), y, (px, py), row) in enumerate(
            zip(found, materials, yaw.tolist(), xy.tolist(), rows, strict=True), start=1):
        length, width = row[7], row[8]
        out.append(Detection(
            id=i,
            material=material,
            material_confidence=round(float(m_conf), 4),
            kind=kind,
            kind_confidence=round(float(conf), 4),
            centroid=(float(res.centroid_px[0]), float(res.centroid_px[1])),
            yaw=y,
            symmetry=KINDS[kind].symmetry if kind in KINDS else 0,
            position=None if blob.partial else (px, py),
            size=(length, width),
            partial=blob.partial,
        ))
    return out


_WARM: set[int] = set()


def _warm_up_kernels(detector: PartDetector) -> None:
    """Load (or, the first time after a clone, compile) the detector's compiled kernels
    once per process, so that no frame pays for it: the geometry kernels with and without
    lens distortion, then two made-up frames (a clean and a noisy one) with two touching
    discs, which run the segmentation, kind, split and material kernels."""
    if _WARM:
        return
    cache = Path(__file__).parent / "__pycache__"
    if not any(cache.glob("*.nbi")):  # numba has not compiled them yet: say why we wait
        print("cell.vision: compiling the detector's kernels (once after install, about a "
              "minute)...", file=sys.stderr, flush=True)
    _warm_up()
    _warm_up_material()
    _warm_up_segment()
    K = np.array([[300.0, 0, 159.5], [0, 300.0, 119.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = (0.0, 0.0, 0.4)
    camera = CameraModel(320, 240, K, np.zeros(5), T)
    img = np.full((240, 320, 3), (60, 80, 110), np.uint8)
    for (u, v), colour in (((140, 120), (200, 60, 50)), ((170, 125), (180, 180, 170))):
        cv2.circle(img, (u, v), 16, colour, -1)
    noisy = cv2.add(img, np.random.default_rng(0).integers(0, 20, img.shape, dtype=np.uint8))
    for frame in (img, noisy):
        detector.detect(frame, camera)
    _warm_up_split()
    ring = np.stack([np.cos(np.arange(12) * np.pi / 6), np.sin(np.arange(12) * np.pi / 6)], 1)
    footprint_yaw(footprint(0.01 * ring), "hex_nut", cut=2)  # the nuts' flat angle
    # the poses of detections (the made-up frames need not yield any): a bolt's, 3-fold
    detection_poses(0.01 * ring, np.array([0, len(ring)]), np.array([[0, 0, 0, 3, 2, 0, 1.0]]),
                    np.empty(1), np.empty((1, 2)))
    _WARM.add(1)
