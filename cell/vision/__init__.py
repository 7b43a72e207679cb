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
