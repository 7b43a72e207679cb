"""``VisionSettings``: the ``[vision]`` section of a scenario, read by ``PartDetector``.

Every field has a default, a range or a set of choices and a one-line doc, so a scenario
file, ``--set vision.key=value`` and ``cell detect --set key=value`` are all validated the
same way (see :mod:`cell.config`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from cell.config import check, setting
from cell.errors import ScenarioError
from cell.text import escape

__all__ = ["SEGMENTATIONS", "VisionSettings"]

_DETECTOR_NAME = re.compile(r"[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)*:[A-Za-z_][\w]*")
SEGMENTATIONS = ("belt", "fixed", "otsu", "iterative", "adaptive")


@dataclass(frozen=True)
class VisionSettings:
    """How ``PartDetector`` separates parts from the belt and names them.

    Foreground is chosen by ``segmentation``: the colour difference from the belt learned
    from the frame (``belt``), or a textbook threshold of the grey image.
    """

    detector: str = setting(
        "parts",
        doc="the detector a job uses: parts (ours) or 'package.module:Class' for your own, any "
        "class whose detect(image, camera) returns Detections (built with no arguments, or "
        "with the VisionSettings if it takes one)",
    )
    segmentation: str = setting(
        "belt",
        choices=SEGMENTATIONS,
        doc="foreground method: belt (difference from the belt learned from the frame, "
        "thresholded at its noise level), or a textbook threshold of the grey image: fixed "
        "(at 'threshold'), otsu, iterative (Ridler-Calvard), adaptive (local mean)",
    )
    threshold: int = setting(
        150, lo=0, hi=255, doc="grey level of the fixed segmentation (parts above it)"
    )
    belt_floor: int = setting(
        8, lo=1, hi=254,
        doc="belt segmentation: the lowest threshold on the colour difference (grey levels)",
    )
    adaptive_block: int = setting(
        101, lo=3, hi=1001, doc="adaptive segmentation: neighbourhood size (px, odd)"
    )
    adaptive_offset: float = setting(
        10.0, lo=0.0, hi=255.0, doc="adaptive segmentation: margin above the local mean (grey levels)"
    )
    noise_k: float = setting(
        4.0, lo=1.0, hi=50.0,
        doc="belt segmentation: the threshold in noise multiples (MAD) above the median difference"
    )
    belt_low: float = setting(
        0.8, lo=0.05, hi=1.0,
        doc="belt segmentation of a noisy frame: hysteresis, the low threshold as a fraction "
        "of the threshold: fainter pixels are foreground where they connect to one above it "
        "(1 = off)",
    )
    smooth: int = setting(
        3, lo=0, hi=15,
        doc="aperture of the Gaussian applied to a noisy frame before differencing (px, odd; "
        "0 = off, and no median against salt and pepper either): the least; a noisier frame "
        "gets a wider one, up to 15, that leaves under 8.5 grey levels of its sensor noise",
    )
    smooth_sigma: float = setting(
        0.0, lo=0.0, hi=5.0,
        doc="sigma of that Gaussian (px; 0: from the aperture, as cv2.GaussianBlur: 0.8 for 3)",
    )
    edge_level: float = setting(
        0.3, lo=0.05, hi=0.95,
        doc="each blob is re-thresholded at this fraction of its contrast's lower quartile "
        "(0.5: the outline where an edge pixel is half covered)",
    )
    shadow_chroma: float = setting(
        0.25, lo=0.0, hi=1.0,
        doc="a pixel darker (shadow) or brighter (a pool of light) than the belt in every "
        "channel, whose ratios to the belt differ by less than this fraction, is the belt "
        "in other light, not part (0 = keep them)",
    )
    plane_z: float = setting(
        0.08, lo=-10.0, hi=10.0, doc="world height of the surface the parts lie on (m)"
    )
    belt_y: tuple[float, ...] = setting(
        (0.37, 0.53), lo=-10.0, hi=10.0, length=2,
        doc="the belt's extent across it, as world y (m, low then high): a blob whose centre "
        "on the table plane lies outside, or within 4 mm of an edge, is no part (a shadow on "
        "the table, a rail, light along the edge)",
    )
    belt_rgb: tuple[float, ...] = setting(
        (0.22, 0.30, 0.42), lo=0.01, hi=1.0, length=3,
        doc="belt reflectance per channel (0.01..1), the white-balance reference",
    )
    min_area_mm2: float = setting(
        40.0, lo=0.0, hi=1e4,
        doc="smallest blob kept, as a table-plane area (mm^2; a kept group's regions from a third)"
    )
    max_area_mm2: float = setting(
        2000.0, lo=1.0, hi=1e5, doc="largest blob that may be one or two parts (mm^2)"
    )
    split_touching: bool = setting(
        True, doc="cut blobs that fit no single kind into touching parts"
    )
    faint_contrast: float = setting(
        1.85, lo=0.0, hi=20.0,
        doc="a blob that fits no kind is searched for touching parts only if the brightest "
        "tenth of it differs from the belt by at least this many times the foreground "
        "threshold: fainter ones are belt texture or noise; a piece of a cut that fits no "
        "kind and is this faint is left out of the cut when no cut fits every piece "
        "(0 = search all, leave none out)",
    )
    partial_min_width: float = setting(
        0.010, lo=0.0, hi=1.0,
        doc="a blob at the image border is reported (as partial) only if at least this wide "
        "(m): thinner strips there are belt edges and rails, or slivers of a part",
    )
    border_margin: int = setting(
        1, lo=0, hi=50, doc="a blob within this many pixels of the image edge is partial (px)"
    )
    backlight_level: int = setting(
        200, lo=0, hi=255,
        doc="median background brightness above which the frame is taken as back-lit",
    )
    grain_metal: float = setting(
        0.04, lo=0.0, hi=1.0,
        doc="relative grain amplitude from which a part counts as grainy (brightness fraction)",
    )
    grain_z_min: float = setting(
        2.5, lo=0.0, hi=100.0, doc="grain evidence needed to count (standard errors)"
    )
    albedo_sigma: float = setting(
        0.08, lo=0.001, hi=1.0, doc="tolerance of the albedo match to catalogue finishes (0..1)"
    )
    min_kind_confidence: float = setting(
        0.5, lo=0.0, hi=1.0, doc="below this kind confidence the kind is reported 'unknown'"
    )

    def __post_init__(self) -> None:
        check(self, "vision")  # every field, however the object was made

    def _validate(self, where: str) -> None:
        if self.detector != "parts" and not _DETECTOR_NAME.fullmatch(self.detector):
            raise ScenarioError(
                f"{where}: key 'vision.detector' must be 'parts' or 'package.module:Class', "
                f"got {escape(repr(self.detector))}")
        if self.smooth and self.smooth % 2 == 0:
            raise ScenarioError(f"{where}: key 'vision.smooth' must be odd or 0, got {self.smooth}")
        if self.adaptive_block % 2 == 0:
            raise ScenarioError(
                f"{where}: key 'vision.adaptive_block' must be odd, got {self.adaptive_block}")
        if self.min_area_mm2 >= self.max_area_mm2:
            raise ScenarioError(
                f"{where}: key 'vision.min_area_mm2' must be below 'vision.max_area_mm2'"
            )
        if self.belt_y[0] >= self.belt_y[1]:
            raise ScenarioError(
                f"{where}: key 'vision.belt_y' must be [low, high] with low < high, got "
                f"{list(self.belt_y)}")
