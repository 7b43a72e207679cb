"""The part detector's steps, one module each, in the order ``PartDetector.detect`` runs
them (see :mod:`cell.vision.detector`):

1. :mod:`~cell.vision.steps.foreground`: which pixels are not the belt;
2. :mod:`~cell.vision.steps.outlines`: one outline per blob, on the part's edge;
3. :mod:`~cell.vision.steps.footprint` and :mod:`~cell.vision.steps.kind`: the outline on
   the table plane, and the catalogue kind it fits;
4. :mod:`~cell.vision.steps.split`: touching parts cut apart;
5. :mod:`~cell.vision.steps.material` and :mod:`~cell.vision.steps.grain`: metal or
   plastic, from the surface's grain and its albedo;
6. :mod:`~cell.vision.steps.pose`: position and yaw on the table plane.

Each step is plain numpy and OpenCV (the pose step also scipy); data passes between them
as frozen dataclasses (and the material step's ``MaterialLabel``, a named tuple).
"""

from __future__ import annotations

from cell.lazy import lazy_names

_WHERE = {
    "Foreground": "foreground", "find_foreground": "foreground",
    "Outline": "outlines", "find_outlines": "outlines",
    "Footprint": "footprint", "TablePlane": "footprint",
    "KindFit": "kind", "fit_kind": "kind",
    "Piece": "split", "split_blob": "split",
    "PartPixels": "material", "part_materials": "material",
    "Pose": "pose", "part_pose": "pose",
}

__all__ = sorted(_WHERE)

__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
