"""Feature-based matching: ORB keypoints, ratio-tested matches, RANSAC homography.

Finds a template (a part's appearance) in a scene at any rotation and at moderate
scale and perspective change, where a sliding template (NCC) only handles the pose it
was cut at.

References: E. Rublee et al., "ORB: an efficient alternative to SIFT or SURF",
ICCV 2011; D. Lowe, "Distinctive image features from scale-invariant keypoints",
IJCV 2004 (ratio test); M. Fischler and R. Bolles, "Random sample consensus",
CACM 24(6), 1981; OpenCV ``cv2.ORB_create``, ``cv2.BFMatcher``,
``cv2.findHomography(..., cv2.RANSAC)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_gray

__all__ = ["FeatureMatch", "orb_match"]


@dataclass(frozen=True, eq=False)
class FeatureMatch:
    """A template found in a scene.

    ``H`` (3x3) maps template pixels (x, y, 1) to scene pixels; ``corners`` (4, 2)
    are the template's corners (top-left, top-right, bottom-right, bottom-left) in
    the scene; ``centre`` (x, y) is the template centre in the scene; ``angle`` the
    in-plane rotation (radians, x right, y down); ``inliers`` / ``matches`` count
    the RANSAC inliers among the ratio-tested matches.
    """

    H: np.ndarray
    corners: np.ndarray
    centre: tuple[float, float]
    angle: float
    inliers: int
    matches: int


def orb_match(
    template: np.ndarray,
    scene: np.ndarray,
    *,
    n_features: int = 1000,
    ratio: float = 0.75,
    ransac_px: float = 3.0,
    min_inliers: int = 10,
    seed: int = 0,
) -> FeatureMatch | None:
    """Find ``template`` in ``scene`` with ORB features and a RANSAC homography.

    Parameters
    ----------
    template, scene : uint8 (h, w) and (H, W) grey images. ORB needs texture and
        size: a template under about 60 px across yields too few keypoints (at the
        overhead camera's 1.65 px/mm most parts are smaller; use the wrist camera).
    n_features : ORB keypoints per image.
    ratio : Lowe's ratio test on the two nearest Hamming neighbours.
    ransac_px : RANSAC reprojection threshold (pixels).
    min_inliers : fewer inliers than this means "not found".
    seed : seeds OpenCV's RNG, which RANSAC draws from, so the result is repeatable.

    Returns a ``FeatureMatch`` or ``None`` when the template is not found.
    """
    template = check_gray("template", template)
    scene = check_gray("scene", scene)
    if not 0 < ratio <= 1:
        raise VisionError(f"argument 'ratio': expected in (0, 1], got {ratio!r}")
    orb = cv2.ORB_create(nfeatures=n_features)
    # ORB ignores a 31 px border (its patch size); pad the template by replicating its
    # edge so keypoints near its outline count, then shift them back.
    pad = 31
    padded = cv2.copyMakeBorder(template, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
    kt, dt = orb.detectAndCompute(padded, None)
    ks, ds = orb.detectAndCompute(scene, None)
    if dt is None or ds is None or len(kt) < 4 or len(ks) < 4:
        return None
    pairs = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(dt, ds, k=2)
    good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < ratio * p[1].distance]
    if len(good) < max(4, min_inliers):
        return None
    src = np.float32([kt[m.queryIdx].pt for m in good]).reshape(-1, 1, 2) - pad
    dst = np.float32([ks[m.trainIdx].pt for m in good]).reshape(-1, 1, 2)
    cv2.setRNGSeed(int(seed))
    H, inl = cv2.findHomography(src, dst, cv2.RANSAC, ransac_px)
    if H is None or inl is None or int(inl.sum()) < min_inliers:
        return None
    h, w = template.shape
    box = np.float32([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]]).reshape(-1, 1, 2)
    corners = cv2.perspectiveTransform(box, H).reshape(-1, 2).astype(np.float64)
    c = cv2.perspectiveTransform(np.float32([[[(w - 1) / 2, (h - 1) / 2]]]), H).reshape(2)
    angle = float(np.arctan2(H[1, 0], H[0, 0]))
    return FeatureMatch(H, corners, (float(c[0]), float(c[1])), angle, int(inl.sum()), len(good))
