"""``PartDetector``: one RGB frame and its camera model in, a list of ``Detection`` out.

What the detector uses: the image, the camera model (intrinsics, distortion, pose), the
``VisionSettings`` (including the belt's nominal reflectance, the white-balance reference)
and the catalogue's nominal part geometry and finishes. It never reads the simulator.
Its background model is learned from the frame itself: a median filter much wider than
any part over a 1/8-scale copy (borders mirrored) estimates the empty belt, and whatever
else surrounds it, under the frame's own lighting, so light gradients, spot lights and
colour temperature need no calibration image. No second image is used.

Pipeline (each step a textbook technique):
1. background estimate (median filter) and per-pixel colour difference (largest channel);
   a noisy frame (MAD > 2 grey levels) is box-filtered first;
2. noise-adaptive threshold (median + k * MAD of the difference, with a floor), or fixed
   or Otsu (``VisionSettings.threshold_method``); an opening removes specks; a frame whose
   background is a bright light table is taken as back-lit;
3. contours with holes (``cv2.findContours``, two-level hierarchy); each blob is then
   re-thresholded at a fraction (``edge_level``) of its own contrast, and shadow pixels
   (darker than the background by one factor in all channels) are dropped;
4. each outline is mapped onto the table plane per candidate kind: a contour point whose
   outward normal faces away from the camera's nadir is a top edge, the others bottom
   edges (a prism seen off-axis shows a wall), so the footprint is free of perspective;
5. kind from footprint descriptors (:mod:`cell.vision.kind`); a blob that fits no kind is
   cut into touching parts (convexity-defect cuts, distance-transform cores), recursively;
6. material from grain and white-balanced albedo (:mod:`cell.vision.material`); yaw per
   kind modulo its symmetry; position the footprint centroid on the table plane (for a
   bolt, a point fixed relative to its two ends). A blob at the image border is reported
   ``partial`` with kind ``unknown`` and no position.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import cv2
import numpy as np

from cell.camera import CameraModel
from cell.catalogue import KINDS
from cell.errors import VisionError
from cell.vision._checks import check_colour
from cell.vision.kind import classify_kind, footprint, footprint_yaw, score_kind
from cell.vision.material import classify_material, material_features
from cell.vision.settings import VisionSettings

__all__ = ["Detection", "PartDetector"]

_BG_SCALE = 8  # the background model's downscale factor
_BG_MEDIAN = 15  # its median aperture at that scale (120 px at full scale)


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


@dataclass
class _Blob:
    contour: np.ndarray  # (N, 2) float pixel outline, outward-shifted by half a pixel
    normals: np.ndarray  # (N, 2) outward unit normals of the part region
    holes: list[tuple[np.ndarray, np.ndarray]]
    mask_box: tuple[int, int, int, int]  # x, y, w, h of the bounding box
    partial: bool
    roi: tuple[int, int, np.ndarray] | None = None  # x0, y0, uint8 mask of the part
    rays: np.ndarray | None = None  # cached by _Geometry._prepare
    away: np.ndarray | None = None
    splits: np.ndarray | None = None


class PartDetector:
    """Finds, names and locates parts in an RGB frame. See the module docstring."""

    def __init__(self, settings: VisionSettings | None = None) -> None:
        self.settings = settings if settings is not None else VisionSettings()
        if not isinstance(self.settings, VisionSettings):
            raise VisionError(
                f"argument 'settings': expected VisionSettings, got {type(settings).__name__}"
            )

    # --- public -----------------------------------------------------------------------
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
        if h < 2 * _BG_SCALE or w < 2 * _BG_SCALE:
            raise VisionError(f"argument 'image': too small ({w}x{h}), need at least 16x16")
        img = np.ascontiguousarray(image)
        bg, backlit = self._background(img)
        dmax, mask, t = self._foreground(img, bg)
        geo = _Geometry(camera, self.settings.plane_z)
        longest = max(k.length for k in KINDS.values())
        self._max_px = int(2.5 * longest / geo.m_per_px)
        self._min_px = self.settings.min_area_mm2 * 1e-6 / geo.m_per_px**2
        self._frame, self._backlit, self._sigma = (img, bg), backlit, None
        self._mask = mask
        blobs = self._blobs(mask, dmax, t)
        found: list[tuple[_Blob, str, float, object]] = []
        for blob in blobs:
            found.extend(self._interpret(blob, mask, geo))
        found.sort(key=lambda f: (f[3].centroid_px[0], f[3].centroid_px[1]))  # type: ignore[attr-defined]
        out = []
        for i, (blob, kind, conf, res) in enumerate(found, start=1):
            material, m_conf = self._material(img, bg, blob, backlit)
            out.append(_make_detection(i, blob, kind, conf, res, material, m_conf))
        return out

    # --- background and foreground ------------------------------------------------------
    def _background(self, img: np.ndarray) -> tuple[np.ndarray, bool]:
        h, w = img.shape[:2]
        s = _BG_SCALE
        small = np.ascontiguousarray(img[s // 2 :: s, s // 2 :: s])
        r = _BG_MEDIAN // 2  # mirror the borders, so a window there sees a whole neighbourhood
        padded = cv2.copyMakeBorder(small, r, r, r, r, cv2.BORDER_REFLECT_101)
        bg_small = np.ascontiguousarray(cv2.medianBlur(padded, _BG_MEDIAN)[r:-r, r:-r])
        probe = bg_small[::3, ::3].reshape(-1, 3)
        hi, lo = probe.max(axis=1), probe.min(axis=1)
        level = float(np.median(hi))
        spread = float(np.median(hi - lo))
        backlit = level >= self.settings.backlight_level and spread < 40
        bg = cv2.resize(bg_small, (w, h), interpolation=cv2.INTER_LINEAR)
        return bg, backlit

    def _foreground(
        self, img: np.ndarray, bg: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """(difference image, foreground mask, threshold) for an RGB frame and its background.

        The difference is the largest channel difference (grey levels). Only when the frame
        is noisy (MAD above 2 grey levels) is the image box-filtered (``smooth``) first, so
        clean frames keep sharp edges.
        """
        st = self.settings
        h, w = img.shape[:2]
        diff = cv2.absdiff(img, bg).reshape(h, w * 3)
        dmax = np.ascontiguousarray(cv2.dilate(diff, np.ones((1, 3), np.uint8))[:, 1::3])
        sample = dmax[4::8, 4::8].astype(np.float32)
        mad = float(np.median(np.abs(sample - np.median(sample)))) * 1.4826
        if st.smooth and mad > 2.0:  # noisy: average the image before differencing
            k = st.smooth
            diff = cv2.absdiff(cv2.blur(img, (k, k)), bg).reshape(h, w * 3)
            dmax = np.ascontiguousarray(cv2.dilate(diff, np.ones((1, 3), np.uint8))[:, 1::3])
            sample = dmax[4::8, 4::8].astype(np.float32)
            mad = float(np.median(np.abs(sample - np.median(sample)))) * 1.4826
        if st.threshold_method == "fixed":
            t = float(st.threshold_value)
        elif st.threshold_method == "otsu":
            otsu = cv2.threshold(dmax, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)[0]
            t = max(float(otsu), float(st.otsu_floor))
        else:  # "auto": noise-adaptive
            t = max(float(st.threshold_value), float(np.median(sample)) + st.noise_k * max(mad, 0.5))
        mask = cv2.threshold(dmax, t, 255, cv2.THRESH_BINARY)[1]
        return dmax, cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)), t

    def _blobs(self, mask: np.ndarray, dmax: np.ndarray | None = None, t: float = 0.0) -> list[_Blob]:
        """Outer contours with their holes; with ``dmax``, each blob is re-thresholded at
        half its own contrast (median difference inside it), so its outline sits where
        the edge is half covered, whatever the part's contrast."""
        h, w = mask.shape
        contours, hier = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
        if hier is None:
            return []
        hier = hier[0]
        m = self.settings.border_margin
        blobs = []
        for i, c in enumerate(contours):
            if len(c) < 24 or hier[i][3] != -1:
                continue  # the smallest part's outline is some 80 px long
            x, y, bw, bh = cv2.boundingRect(c)
            if bw * bh < 20 or max(bw, bh) > self._max_px or cv2.contourArea(c) < self._min_px:
                continue  # a speck, or far longer than any part: a rail, the table edge
            if dmax is not None:
                blobs.extend(self._refine(c, contours, hier, i, mask, dmax, t))
                continue
            partial = x <= m or y <= m or x + bw >= w - m or y + bh >= h - m
            blobs.append(_make_blob(c.reshape(-1, 2), contours, hier, i, (0, 0), partial))
        return blobs

    def _refine(self, c, contours, hier, i, mask, dmax, t) -> list[_Blob]:
        h, w = mask.shape
        mgn = self.settings.border_margin
        x, y, bw, bh = cv2.boundingRect(c)
        x0, y0 = max(x - 2, 0), max(y - 2, 0)
        x1, y1 = min(x + bw + 2, w), min(y + bh + 2, h)
        own = np.zeros((y1 - y0, x1 - x0), np.uint8)
        cv2.drawContours(own, [c.reshape(-1, 2) - [x0, y0]], -1, 255, -1)
        d = dmax[y0:y1, x0:x1]
        inside = d[(own > 0) & (mask[y0:y1, x0:x1] > 0)]
        half = inside.size // 2
        level = t
        if inside.size:
            level = max(t, self.settings.edge_level * float(np.partition(inside, half)[half]))
        own = cv2.dilate(own, np.ones((3, 3), np.uint8))
        keep = (d > level) & (own > 0)
        img, bg = self._frame
        if not self._backlit:  # a light table casts no shadows; silhouettes are neutral
            keep &= ~_shadow(img[y0:y1, x0:x1], bg[y0:y1, x0:x1], self.settings.shadow_chroma)
        sub = keep.astype(np.uint8) * 255
        sub = cv2.morphologyEx(sub, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
        cs, hr = cv2.findContours(sub, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
        if hr is None:
            return []
        hr = hr[0]
        out = []
        labels = None
        n_outer = int(np.count_nonzero(hr[:, 3] == -1))
        for j, cj in enumerate(cs):
            if hr[j][3] != -1 or len(cj) < 8:
                continue
            bx, by, bbw, bbh = cv2.boundingRect(cj)
            bx, by = bx + x0, by + y0
            partial = bx <= mgn or by <= mgn or bx + bbw >= w - mgn or by + bbh >= h - mgn
            blob = _make_blob(cj.reshape(-1, 2), cs, hr, j, (x0, y0), partial)
            if n_outer == 1:
                own_mask = sub
            else:
                if labels is None:
                    _, labels = cv2.connectedComponents(sub, connectivity=8)
                px, py = cj[0, 0]
                own_mask = (labels == labels[py, px]).astype(np.uint8) * 255
            blob.roi = (x0, y0, own_mask)  # this part's pixels only, not a neighbour's
            out.append(blob)
        return out

    # --- kinds ----------------------------------------------------------------------------
    def _fit(self, blob: _Blob, geo: _Geometry) -> tuple[str, float, float, _Fit]:
        """Best kind for a blob: classify on a mid-height footprint, refine the top two."""
        mid = geo.footprint(blob, 0.0025, 0.0025)
        if mid is None:
            return "unknown", 0.0, math.inf, _Fit(None, 0.0025)
        rough = {k: score_kind(mid, k) for k in KINDS}
        order = sorted(rough, key=rough.get)[:2]
        if rough[order[1]] > rough[order[0]] + 12.0:
            order = order[:1]
        scores, fits = dict(rough), {}
        for k in order:
            lo, hi = _edge_heights(k)
            if k == "bolt":
                lo, hi = _bolt_heights(blob, geo, mid)
            fp = geo.footprint(blob, lo, hi)
            if fp is not None:
                scores[k] = score_kind(fp, k)
                fits[k] = _Fit(fp, (lo + hi) / 2)
        kind, conf, fit = classify_kind(scores)
        if kind == "unknown" or conf < self.settings.min_kind_confidence:
            return "unknown", conf, fit, _Fit(mid, 0.0025)
        return kind, conf, fit, fits.get(kind, _Fit(mid, 0.0025))

    def _interpret(self, blob: _Blob, mask: np.ndarray, geo: _Geometry) -> list:
        st = self.settings
        area_mm2 = geo.area_mm2(blob)
        if area_mm2 < st.min_area_mm2:
            return []
        if blob.partial:
            res = _Fit(geo.footprint(blob, 0.0025, 0.0025), 0.0025, centroid_px=_px_centroid(blob))
            longest = max(k.length for k in KINDS.values())
            if (res.fp is None or area_mm2 > st.max_area_mm2 or res.fp.length > 1.3 * longest
                    or res.fp.width < st.partial_min_width):
                return []  # not a part: a rail, a belt edge, the table beyond; or a sliver
            return [(blob, "unknown", 0.0, res)]
        kind, conf, fit, res = self._fit(blob, geo)
        if kind != "unknown" and fit < 9.0:
            res.centroid_px = _px_centroid(blob)
            return [(blob, kind, conf, res)]
        if st.split_touching and area_mm2 > 1.5 * st.min_area_mm2:
            pieces = self._split(blob, mask, geo)
            if pieces:
                return pieces
        if kind == "unknown" or area_mm2 > st.max_area_mm2:
            return []
        res.centroid_px = _px_centroid(blob)
        return [(blob, kind, conf, res)]

    def _split(self, blob: _Blob, mask: np.ndarray, geo: _Geometry, depth: int = 0) -> list:
        """Cut a blob that fits no kind into touching parts, each of which must fit one.

        Candidates: cuts between pairs of deep convexity defects (two convex parts that
        touch leave a notch on each side of the contact; the shortest cuts between deep
        notches are tried), then cores of the distance transform at a few depths, each
        pixel going to its nearest core (erosion-based separation). The candidate whose
        pieces fit their kinds best wins. A piece that fits no kind is split again (chains
        of up to four parts).
        """
        x, y, bw, bh = blob.mask_box
        ox, oy = x - 1, y - 1
        roi = np.zeros((bh + 2, bw + 2), np.uint8)
        outline = np.round(blob.contour - 0.5 * blob.normals).astype(np.int32) - [ox, oy]
        cv2.drawContours(roi, [outline], -1, 255, -1)
        filled = roi.copy()  # holes filled: a washer's core is its whole disc
        for hole, hn in blob.holes:
            hp = np.round(hole - 0.5 * hn).astype(np.int32) - [ox, oy]
            cv2.drawContours(roi, [hp], -1, 0, -1)
        best, best_cost = [], math.inf
        for seeds in self._cut_candidates(filled):
            pieces = self._pieces(roi, seeds, (ox, oy), geo, mask, depth)
            if not pieces:
                continue
            cost = sum(p[4] for p in pieces) / len(pieces)
            if cost < best_cost:
                best, best_cost = [p[:4] for p in pieces], cost
            if best_cost < 4.0:
                break  # every piece fits its kind well: no need to try more cuts
        return best if best_cost < 9.0 else []

    def _cut_candidates(self, roi: np.ndarray):
        """Seed images (uint8, pieces labelled 1..n) for possible splits of ``roi``."""
        contours, _ = cv2.findContours(roi, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        if contours:
            c = max(contours, key=len)
            hull = cv2.convexHull(c, returnPoints=False)
            defects = None
            if len(c) >= 5 and hull is not None and len(hull) >= 4:
                try:
                    defects = cv2.convexityDefects(c, hull)
                except cv2.error:
                    defects = None
            if defects is not None:
                deep = [(d[0][3] / 256.0, tuple(c[d[0][2]][0])) for d in defects
                        if d[0][3] >= 2.5 * 256]
                deep.sort(reverse=True)
                deep = deep[:6]
                pairs = []
                for i in range(len(deep)):
                    for j in range(i + 1, len(deep)):
                        (di, pi), (dj, pj) = deep[i], deep[j]
                        pairs.append((math.dist(pi, pj) / (di + dj), pi, pj))
                pairs.sort()
                for _, pi, pj in pairs[:6]:
                    cut = roi.copy()
                    cv2.line(cut, pi, pj, 0, 2)
                    n, labels = cv2.connectedComponents(cut, connectivity=4)
                    if n == 3:
                        yield labels.astype(np.uint8)
        dist = cv2.distanceTransform(roi, cv2.DIST_L2, 3)
        for level in (3.0, 5.0, 8.0, 12.0):
            cores = (dist > level).astype(np.uint8)
            n, labels = cv2.connectedComponents(cores)
            if 3 <= n <= 4:
                yield labels.astype(np.uint8)

    def _pieces(self, roi, seeds, offset, geo, mask, depth) -> list:
        """Every pixel of ``roi`` to its nearest seed; each piece must fit a kind (or, up to
        ``depth`` 2, split again into pieces that do)."""
        _, near = cv2.distanceTransformWithLabels(
            (seeds == 0).astype(np.uint8), cv2.DIST_L2, 3, labelType=cv2.DIST_LABEL_PIXEL
        )
        ys, xs = np.nonzero(seeds)
        lookup = np.zeros(near.max() + 1, np.uint8)
        # DIST_LABEL_PIXEL numbers the zero pixels (the seeds) in row-major order
        lookup[1 : len(ys) + 1] = seeds[ys, xs]
        owner = lookup[near]
        out = []
        for lab in range(1, int(seeds.max()) + 1):
            piece = ((owner == lab) & (roi > 0)).astype(np.uint8) * 255
            if cv2.countNonZero(piece) < 30:
                return []
            sub = self._blobs_offset(piece, offset)
            if len(sub) != 1:
                return []
            sub[0].roi = (offset[0], offset[1], piece)
            kind, conf, fit, res = self._fit(sub[0], geo)
            if kind == "unknown" or fit >= 9.0:
                more = self._split(sub[0], mask, geo, depth + 1) if depth < 2 else []
                if more:
                    out.extend((*p, 4.0) for p in more)  # accepted by _split: fit < 9
                    continue
                if kind == "unknown":
                    return []
            res.centroid_px = _px_centroid(sub[0])
            out.append((sub[0], kind, conf, res, fit))
        return out

    def _blobs_offset(self, piece: np.ndarray, offset: tuple[int, int]) -> list[_Blob]:
        contours, hier = cv2.findContours(piece, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
        if hier is None:
            return []
        hier = hier[0]
        return [
            _make_blob(c.reshape(-1, 2), contours, hier, i, offset, False)
            for i, c in enumerate(contours)
            if hier[i][3] == -1 and len(c) >= 8 and cv2.contourArea(c) >= 30
        ]

    def _belt_near(self, img, bg, x0, y0, x1, y1) -> np.ndarray:
        """The belt's colour next to a part: the mean of the background pixels in a window
        around it (the median-filtered estimate is biased near a part in a noisy frame)."""
        h, w = img.shape[:2]
        xa, ya, xb, yb = max(x0 - 6, 0), max(y0 - 6, 0), min(x1 + 6, w), min(y1 + 6, h)
        free = cv2.bitwise_not(self._mask[ya:yb, xa:xb])
        if cv2.countNonZero(free) < 30:
            return bg[min((y0 + y1) // 2, h - 1), min((x0 + x1) // 2, w - 1)]
        return np.array(cv2.mean(img[ya:yb, xa:xb], mask=free)[:3])

    def _noise_sigma(self, img: np.ndarray) -> float:
        """The frame's sensor noise (grey levels, green channel), from differences of pixels
        two apart on every 16th row: robust (MAD), so edges and grain, a minority, do not
        count."""
        if self._sigma is None:
            rows = img[4::16, ::2, 1].astype(np.int16)
            d = (rows[:, 1:] - rows[:, :-1]).ravel()
            k = d.size // 2
            mad = float(np.partition(np.abs(d - np.partition(d, k)[k]), k)[k])
            self._sigma = 1.4826 * mad / math.sqrt(2)
        return self._sigma

    # --- material -------------------------------------------------------------------------
    def _material(
        self, img: np.ndarray, bg: np.ndarray, blob: _Blob, backlit: bool
    ) -> tuple[str, float]:
        st = self.settings
        if backlit:
            return "unknown", 0.0
        x, y, bw, bh = blob.mask_box
        h, w = img.shape[:2]
        if blob.roi is None:
            return "unknown", 0.0
        x0, y0, roi = blob.roi
        # The interior, away from the edge's blend with the belt: a 5x5 erosion, or 3x3
        # where that leaves too little (a square nut's ring is 4 px wide).
        sel = cv2.erode(roi, np.ones((5, 5), np.uint8)) > 0
        if int(np.count_nonzero(sel)) < 150:
            sel = cv2.erode(roi, np.ones((3, 3), np.uint8)) > 0
        if int(np.count_nonzero(sel)) < 8:
            return "unknown", 0.0
        x1, y1 = x0 + roi.shape[1], y0 + roi.shape[0]
        belt = self._belt_near(img, bg, x0, y0, x1, y1)
        if float(np.min(belt)) >= st.backlight_level:
            return "unknown", 0.0  # a glowing light table behind this part: a silhouette
        feats = material_features(img[y0:y1, x0:x1], sel, belt, belt_rgb=st.belt_rgb,
                                  noise_sigma=self._noise_sigma(img))
        return classify_material(
            feats,
            backlit=False,
            grain_metal=st.grain_metal,
            grain_z_min=st.grain_z_min,
            albedo_sigma=st.albedo_sigma,
        )


@dataclass
class _Fit:
    fp: object  # Footprint | None
    z_mid: float  # height of the footprint's centre above the belt (m)
    centroid_px: tuple[float, float] = (0.0, 0.0)


def _shadow(img: np.ndarray, bg: np.ndarray, chroma: float) -> np.ndarray:
    """Pixels that are the background darkened without a change of colour: shadow.

    A shadow scales the light falling on the belt, so every channel drops by about the
    same factor; a part changes the ratios (Cucchiara et al., *Detecting moving objects,
    ghosts and shadows in video streams*, IEEE PAMI 2003: shadows keep chromaticity).
    A shadow pixel is below 0.75 of the background in every channel and ``chroma`` bounds
    the spread of the three ratios, relative to their largest; 0 = off.
    """
    if chroma <= 0:
        return np.zeros(img.shape[:2], bool)
    h, w = img.shape[:2]
    ratio = cv2.divide(cv2.blur(img, (3, 3)), cv2.add(bg, 1), dtype=cv2.CV_32F)
    ratio = ratio.reshape(h, w * 3)
    k = np.ones((1, 3), np.uint8)  # max / min over each pixel's three channels
    rmax = cv2.dilate(ratio, k)[:, 1::3]
    rmin = cv2.erode(ratio, k)[:, 1::3]
    return (rmax < 0.75) & (rmin > (1.0 - chroma) * rmax)


def _make_blob(pts, contours, hier, i, offset, partial) -> _Blob:
    off = np.array(offset)
    pts = pts + off
    outline, normals = _outline(pts, hole=False)
    holes = []
    j = hier[i][2]
    while j != -1:
        hc = contours[j].reshape(-1, 2) + off
        if len(hc) >= 6:
            holes.append(_outline(hc, hole=True))
        j = hier[j][0]
    bx, by, bw, bh = cv2.boundingRect(pts.astype(np.int32))
    return _Blob(outline, normals, holes, (bx, by, bw, bh), partial)


def _bolt_heights(blob: _Blob, geo: _Geometry, mid) -> tuple[np.ndarray, np.ndarray]:
    """Per-point silhouette edge heights of a lying bolt (cell.sim.parts geometry).

    The head (10 mm across flats, its corners 11.5 mm high, 4 mm long) stands like a
    prism from the belt to its top; the 6 mm shank, tilted up towards the head, shows
    its tangent lines between about 1.5 and 8.5 mm. The head is the wider end of the
    mid-height footprint.
    """
    geo._prepare(blob)
    xy = geo._meet(blob.rays, geo.plane_z + 0.0025)
    axis = np.array([math.cos(mid.rect_angle), math.sin(mid.rect_angle)])
    s = (xy - mid.centroid) @ axis
    t = np.abs((xy - mid.centroid) @ np.array([-axis[1], axis[0]]))
    ends = s.max(), s.min()
    near_max = t[s > ends[0] - 0.004]
    near_min = t[s < ends[1] + 0.004]
    head_at_max = (near_max.max() if near_max.size else 0) > (near_min.max() if near_min.size else 0)
    head = s > ends[0] - 0.005 if head_at_max else s < ends[1] + 0.005
    h = KINDS["bolt"].height
    lo = np.where(head, 0.0, 0.0015)
    hi = np.where(head, h, 0.0085)
    return lo, hi


_BOLT_END_OFFSET = 0.0014  # body origin from the middle of the bolt's ends, towards the head


def _bolt_origin(fp) -> np.ndarray:
    """A bolt's reference point: on its axis, 1.4 mm from the middle of its two ends
    towards the head (cell.sim.parts: ends at -20.6 and +23.4 mm). The area centroid
    would move with the head's roll (10 or 11.5 mm wide); the ends do not."""
    axis = np.array([math.cos(fp.rect_angle), math.sin(fp.rect_angle)])
    rel = fp.outline - fp.centroid
    s = rel @ axis
    t = rel @ np.array([-axis[1], axis[0]])
    s_max, s_min = float(s.max()), float(s.min())
    w_max = float(np.abs(t[s > s_max - 0.004]).max())
    w_min = float(np.abs(t[s < s_min + 0.004]).max())
    to_head = 1.0 if w_max > w_min else -1.0
    mid = 0.5 * (s_max + s_min) + to_head * _BOLT_END_OFFSET
    return fp.centroid + mid * axis


def _edge_heights(kind: str) -> tuple[float, float]:
    """Heights above the belt (m) of a kind's silhouette edges: facing the nadir, away."""
    h = KINDS[kind].height
    if kind == "bolt":  # a lying cylinder: its silhouette is near its axis height
        return 0.5 * h - 0.0015, 0.5 * h + 0.0015
    return 0.0, h


def _outline(pts: np.ndarray, *, hole: bool) -> tuple[np.ndarray, np.ndarray]:
    """A pixel contour shifted half a pixel outward, with the part region's outward normals.

    Contours from ``findContours`` run through the centres of edge pixels; the region's
    edge lies half a pixel further out. For a hole contour "outward" points into the hole.
    """
    p = pts.astype(np.float64)
    n_pts = len(p)
    idx = np.arange(n_pts)
    t = p[(idx + 2) % n_pts] - p[idx - 2]
    n = np.stack([t[:, 1], -t[:, 0]], axis=1)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-9)
    if cv2.contourArea(pts.astype(np.float32), oriented=True) < 0:
        n = -n
    if hole:
        n = -n
    return p + 0.5 * n, n


def _px_centroid(blob: _Blob) -> tuple[float, float]:
    m = cv2.moments(blob.contour.astype(np.float32))
    a = m["m00"]
    cx, cy = m["m10"], m["m01"]
    for hole, _ in blob.holes:
        mh = cv2.moments(hole.astype(np.float32))
        a, cx, cy = a - mh["m00"], cx - mh["m10"], cy - mh["m01"]
    if abs(a) < 1e-9:
        c = blob.contour.mean(axis=0)
        return float(c[0]), float(c[1])
    return float(cx / a), float(cy / a)


class _Geometry:
    """Pixel rays of one camera, intersected with horizontal planes (world z up)."""

    def __init__(self, camera: CameraModel, plane_z: float) -> None:
        self.camera = camera
        self.plane_z = plane_z
        self.R = camera.T_world_camera[:3, :3]
        self.o = camera.T_world_camera[:3, 3]
        nad = camera.K @ (self.R.T @ np.array([0.0, 0.0, -1.0]))
        self.nadir = nad[:2] / nad[2] if nad[2] > 1e-9 else None
        centre = self.to_plane(
            np.array([[camera.K[0, 2], camera.K[1, 2]], [camera.K[0, 2] + 1, camera.K[1, 2]]]),
            np.full(2, plane_z),
        )
        self.m_per_px = float(np.linalg.norm(centre[1] - centre[0]))

    def rays(self, pts: np.ndarray) -> np.ndarray:
        """World directions (N, 3) of the rays through pixels (N, 2), lens distortion removed."""
        K, dist = self.camera.K, self.camera.dist
        if np.any(dist):  # as cell.vision.geometry.pixel_to_table: iterated to 1e-14
            norm = cv2.undistortPointsIter(
                pts.reshape(-1, 1, 2).astype(np.float64), K, dist, np.eye(3), np.eye(3),
                (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14),
            )
            xy = norm.reshape(-1, 2)
        else:
            y = (pts[:, 1] - K[1, 2]) / K[1, 1]
            x = (pts[:, 0] - K[0, 2] - K[0, 1] * y) / K[0, 0]
            xy = np.stack([x, y], axis=1)
        d = np.column_stack([xy, np.ones(len(xy))])
        return d @ self.R.T

    def to_plane(self, pts: np.ndarray, z: np.ndarray) -> np.ndarray:
        """World (x, y) (N, 2) where the rays through pixels ``pts`` meet heights ``z`` (m)."""
        return self._meet(self.rays(pts), z)

    def _meet(self, d: np.ndarray, z: np.ndarray | float) -> np.ndarray:
        dz = np.where(np.abs(d[:, 2]) < 1e-12, -1e-12, d[:, 2])
        s = (z - self.o[2]) / dz
        return self.o[:2] + s[:, None] * d[:, :2]

    def _prepare(self, blob: _Blob) -> None:
        """Rays through the blob's outline and holes, and which points face away from the
        nadir (top edges), computed once per blob (cached on it)."""
        if blob.rays is not None:
            return
        pts = [blob.contour] + [h for h, _ in blob.holes]
        nrm = [blob.normals] + [n for _, n in blob.holes]
        allp = np.concatenate(pts)
        alln = np.concatenate(nrm)
        blob.rays = self.rays(allp)
        if self.nadir is None:
            blob.away = np.zeros(len(allp), bool)
        else:
            blob.away = np.einsum("ij,ij->i", alln, allp - self.nadir) > 0
        blob.splits = np.cumsum([len(p) for p in pts])[:-1]

    def footprint(self, blob: _Blob, lo, hi):
        """The blob's footprint on the table plane for silhouette edges at heights ``lo``
        (edges facing the nadir) and ``hi`` (facing away), metres above the surface:
        scalars, or arrays with one height per outline point (outline, then holes)."""
        self._prepare(blob)
        z = self.plane_z + np.where(blob.away, hi, lo)
        xy = self._meet(blob.rays, z)
        parts = np.split(xy, blob.splits)
        try:
            return footprint(parts[0], parts[1:])
        except VisionError:
            return None

    def area_mm2(self, blob: _Blob) -> float:
        a = abs(cv2.contourArea(blob.contour.astype(np.float32)))
        a -= sum(abs(cv2.contourArea(h.astype(np.float32))) for h, _ in blob.holes)
        return a * (self.m_per_px * 1e3) ** 2


def _make_detection(i, blob, kind, conf, res, material, m_conf) -> Detection:
    fp = res.fp
    sym = KINDS[kind].symmetry if kind in KINDS else 0
    yaw = footprint_yaw(fp, kind) if (fp is not None and kind in KINDS) else 0.0
    position = None
    if not blob.partial and fp is not None:
        c = _bolt_origin(fp) if kind == "bolt" else fp.centroid
        position = (float(c[0]), float(c[1]))
    size = (float(fp.length), float(fp.width)) if fp is not None else (0.0, 0.0)
    return Detection(
        id=i,
        material=material,
        material_confidence=round(float(m_conf), 4),
        kind=kind,
        kind_confidence=round(float(conf), 4),
        centroid=(float(res.centroid_px[0]), float(res.centroid_px[1])),
        yaw=float(yaw),
        symmetry=sym,
        position=position,
        size=size,
        partial=blob.partial,
    )
