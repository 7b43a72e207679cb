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
from cell.vision._checks import check_gray, check_int, check_range

__all__ = ["FeatureMatch", "orb_match"]

MAX_FEATURES = 100_000
PATCH = 31  # ORB's patch size and edge threshold: no keypoint lies closer to the border


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
) -> FeatureMatch | None:
    """Find ``template`` in ``scene`` with ORB features and a RANSAC homography.

    Parameters
    ----------
    template, scene : uint8 (h, w) and (H, W) grey images. ORB needs texture and
        size: a template under about 60 px across yields too few keypoints (at the
        overhead camera's 1.65 px/mm most parts are smaller; use the wrist camera).
    n_features : ORB keypoints per image, 4 to 100_000.
    ratio : Lowe's ratio test on the two nearest Hamming neighbours, in (0, 1].
    ransac_px : RANSAC reprojection threshold (pixels), in (0, 1000].
    min_inliers : fewer inliers than this means "not found", 4 to 100_000 (a
        homography takes 4).

    Returns a ``FeatureMatch`` or ``None`` when the template is not found (always
    for a scene under 63 px on a side: ORB finds no keypoint there). The same images
    give the same match: OpenCV's RANSAC draws from its own fixed-seed generator (not
    the one ``cv2.setRNGSeed`` sets).
    """
    template = check_gray("template", template)
    scene = check_gray("scene", scene)
    if check_range("ratio", ratio, 0.0, 1.0) == 0:
        raise VisionError("argument 'ratio': expected a number in (0, 1], got 0")
    n_features = check_int("n_features", n_features, 4, MAX_FEATURES)
    if check_range("ransac_px", ransac_px, 0.0, 1000.0) == 0:
        raise VisionError("argument 'ransac_px': expected a number in (0, 1000], got 0")
    min_inliers = check_int("min_inliers", min_inliers, 4, MAX_FEATURES)
    if min(scene.shape) < 2 * PATCH + 1:  # and ORB's pyramid fails on a 1-pixel side
        return None
    orb = cv2.ORB_create(nfeatures=n_features)
    # ORB ignores a 31 px border (its patch size); pad the template by replicating its
    # edge so keypoints near its outline count, then shift them back.
    pad = PATCH
    padded = cv2.copyMakeBorder(template, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
    kt, dt = orb.detectAndCompute(padded, None)
    ks, ds = orb.detectAndCompute(scene, None)
    if dt is None or ds is None or len(kt) < 4 or len(ks) < 4:
        return None
    pairs = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(dt, ds, k=2)
    good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < ratio * p[1].distance]
    if len(good) < min_inliers:
        return None
    src = np.float32([kt[m.queryIdx].pt for m in good]).reshape(-1, 1, 2) - pad
    dst = np.float32([ks[m.trainIdx].pt for m in good]).reshape(-1, 1, 2)
    H, inl = cv2.findHomography(src, dst, cv2.RANSAC, float(ransac_px))
    if H is None or inl is None or int(inl.sum()) < min_inliers:
        return None
    h, w = template.shape
    box = np.float32([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]]).reshape(-1, 1, 2)
    corners = cv2.perspectiveTransform(box, H).reshape(-1, 2).astype(np.float64)
    c = cv2.perspectiveTransform(np.float32([[[(w - 1) / 2, (h - 1) / 2]]]), H).reshape(2)
    angle = float(np.arctan2(H[1, 0], H[0, 0]))
    return FeatureMatch(H, corners, (float(c[0]), float(c[1])), angle, int(inl.sum()), len(good))
