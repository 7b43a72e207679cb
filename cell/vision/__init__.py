# PartDetector and its classifiers (detector.py, kind.py, material.py, settings.py).
from cell.vision.detector import Detection, PartDetector
from cell.vision.kind import (
    Footprint,
    classify_kind,
    footprint,
    footprint_yaw,
    score_kind,
)
from cell.vision.material import (
    MaterialFeatures,
    classify_material,
    material_features,
)
from cell.vision.settings import VisionSettings

__all__ = [
    "Detection",
    "Footprint",
    "MaterialFeatures",
    "PartDetector",
    "VisionSettings",
    "classify_kind",
    "classify_material",
    "footprint",
    "footprint_yaw",
    "material_features",
    "score_kind",
]

# Syllabus techniques, one module each (see each module's docstring for its reference).
from cell.vision.colour import ColourStats, colour_stats, convert_colour  # noqa: E402
from cell.vision.corners import (  # noqa: E402
    harris_corners,
    harris_response,
    non_max_suppression,
)
from cell.vision.edges import EdgeClosure, Gradient, canny, contour_closure, sobel  # noqa: E402
from cell.vision.features import FeatureMatch, orb_match  # noqa: E402
from cell.vision.geometry import (  # noqa: E402
    PlanarPose,
    apply_homography,
    birdseye_view,
    homography_from_points,
    pixel_to_table,
    solve_planar_pnp,
    table_homography,
)
from cell.vision.labeling import Components, label_components  # noqa: E402
from cell.vision.morphology import (  # noqa: E402
    closing,
    dilate,
    erode,
    fill_holes,
    opening,
    separate_touching,
    structuring_element,
)
from cell.vision.occupancy import OccupancyGrid, bfs_path, occupancy_grid  # noqa: E402
from cell.vision.pixel import invert, quantize  # noqa: E402
from cell.vision.regions import region_grow, split_and_merge  # noqa: E402
from cell.vision.rle import (  # noqa: E402
    CodingSizes,
    RunLength,
    coding_sizes,
    rle_decode,
    rle_encode,
    rle_from_bytes,
    rle_to_bytes,
)
from cell.vision.shape import (  # noqa: E402
    ShapeDescriptors,
    aspect_ratio,
    circularity,
    compactness,
    count_holes,
    describe_shape,
    hu_moments,
    orientation,
    perimeter,
)
from cell.vision.smoothing import gaussian_iterated, median  # noqa: E402
from cell.vision.template import (  # noqa: E402
    Match,
    TemplateDecision,
    best_match,
    match_ncc,
    match_sad,
    match_ssd,
    two_template_decision,
)
from cell.vision.threshold import (  # noqa: E402
    threshold_adaptive,
    threshold_fixed,
    threshold_iterative,
    threshold_otsu,
)

__all__ += [
    "CodingSizes",
    "ColourStats",
    "Components",
    "EdgeClosure",
    "FeatureMatch",
    "Gradient",
    "Match",
    "OccupancyGrid",
    "PlanarPose",
    "RunLength",
    "ShapeDescriptors",
    "TemplateDecision",
    "apply_homography",
    "aspect_ratio",
    "best_match",
    "bfs_path",
    "birdseye_view",
    "canny",
    "circularity",
    "closing",
    "coding_sizes",
    "colour_stats",
    "compactness",
    "contour_closure",
    "convert_colour",
    "count_holes",
    "describe_shape",
    "dilate",
    "erode",
    "fill_holes",
    "gaussian_iterated",
    "harris_corners",
    "harris_response",
    "homography_from_points",
    "hu_moments",
    "invert",
    "label_components",
    "match_ncc",
    "match_sad",
    "match_ssd",
    "median",
    "non_max_suppression",
    "occupancy_grid",
    "opening",
    "orb_match",
    "orientation",
    "perimeter",
    "pixel_to_table",
    "quantize",
    "region_grow",
    "rle_decode",
    "rle_encode",
    "rle_from_bytes",
    "rle_to_bytes",
    "separate_touching",
    "sobel",
    "solve_planar_pnp",
    "split_and_merge",
    "structuring_element",
    "table_homography",
    "threshold_adaptive",
    "threshold_fixed",
    "threshold_iterative",
    "threshold_otsu",
    "two_template_decision",
]
