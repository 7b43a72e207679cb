"""``cell.vision``: image -> facts, numpy, OpenCV and scipy; never imports mujoco.

The part detector (:class:`PartDetector`, its steps in :mod:`cell.vision.steps`) and the
syllabus techniques, one module each (each module's docstring names its reference).
Names load lazily, on first use, so that loading a scenario (which reads
:class:`VisionSettings`) does not import the detector.
"""

from __future__ import annotations

from cell.lazy import lazy_names

_WHERE = {
    # the part detector and its settings
    "Detection": "detector",
    "PartDetector": "detector",
    "StepTimes": "detector",
    "VisionSettings": "settings",
    "Footprint": "steps.footprint",
    "describe_footprint": "steps.footprint:describe",
    "KindFit": "steps.kind",
    "classify_kind": "steps.kind",
    "fit_kind": "steps.kind",
    "score_kinds": "steps.kind",
    "kind_yaw": "steps.pose",
    "MaterialFeatures": "steps.material",
    "MaterialLabel": "steps.material",
    "classify_material": "steps.material",
    "material_features": "steps.material",
    # syllabus techniques
    "CodingSizes": "rle",
    "ColourStats": "colour",
    "Components": "labeling",
    "EdgeClosure": "edges",
    "FeatureMatch": "features",
    "Gradient": "edges",
    "Match": "template",
    "OccupancyGrid": "occupancy",
    "PlanarPose": "geometry",
    "RunLength": "rle",
    "ShapeDescriptors": "shape",
    "TemplateDecision": "template",
    "apply_homography": "geometry",
    "aspect_ratio": "shape",
    "best_match": "template",
    "bfs_path": "occupancy",
    "birdseye_view": "geometry",
    "canny": "edges",
    "circularity": "shape",
    "closing": "morphology",
    "coding_sizes": "rle",
    "colour_stats": "colour",
    "compactness": "shape",
    "contour_closure": "edges",
    "convert_colour": "colour",
    "count_holes": "shape",
    "describe_shape": "shape",
    "dilate": "morphology",
    "erode": "morphology",
    "fill_holes": "morphology",
    "gaussian_iterated": "smoothing",
    "harris_corners": "corners",
    "harris_response": "corners",
    "homography_from_points": "geometry",
    "hu_moments": "shape",
    "invert": "pixel",
    "label_components": "labeling",
    "match_ncc": "template",
    "match_sad": "template",
    "match_ssd": "template",
    "median": "smoothing",
    "no_ray": "geometry",
    "non_max_suppression": "corners",
    "occupancy_grid": "occupancy",
    "opening": "morphology",
    "orb_match": "features",
    "orientation": "shape",
    "perimeter": "shape",
    "pixel_to_table": "geometry",
    "quantize": "pixel",
    "region_grow": "regions",
    "rle_decode": "rle",
    "rle_encode": "rle",
    "rle_from_bytes": "rle",
    "rle_to_bytes": "rle",
    "separate_touching": "morphology",
    "sobel": "edges",
    "solve_planar_pnp": "geometry",
    "split_and_merge": "regions",
    "structuring_element": "morphology",
    "table_homography": "geometry",
    "threshold_adaptive": "threshold",
    "threshold_fixed": "threshold",
    "threshold_hysteresis": "threshold",
    "threshold_iterative": "threshold",
    "threshold_otsu": "threshold",
    "two_template_decision": "template",
    "unclipped_mean": "colour",
}

__all__ = sorted(_WHERE)

__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
