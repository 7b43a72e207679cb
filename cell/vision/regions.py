"""Region-based segmentation: seeded region growing and split-and-merge (quadtree).

Both group pixels by similarity of grey level (or colour) and adjacency instead of
by a single global threshold, so they find uniform parts on a textured belt whose
grey levels span the parts' own.

References: R. Adams and L. Bischof, "Seeded region growing", IEEE PAMI 16(6), 1994;
S. L. Horowitz and T. Pavlidis, "Picture segmentation by a tree traversal algorithm",
JACM 23(2), 1976 (split-and-merge); Gonzalez & Woods, *Digital Image Processing*,
4th ed., 10.4.
"""

from __future__ import annotations

import cv2
import numpy as np

from cell.errors import VisionError
from cell.vision._checks import check_choice, check_image, check_int, check_points, check_range

__all__ = ["region_grow", "split_and_merge"]


MAX_AREA = 2**31 - 1  # pixels: the largest min_area
MAX_BLOCK = 1 << 16  # split_and_merge's largest min_size (pixels)
MAX_ITERATIONS = 10_000_000  # growth rings; a ring adds >= 1 pixel, so H*W rings at most run


def _as_float(image: np.ndarray) -> np.ndarray:
    img = image.astype(np.float32)
    return img[:, :, None] if img.ndim == 2 else img


def region_grow(
    image: np.ndarray,
    seeds: np.ndarray,
    *,
    tolerance: float,
    criterion: str = "mean",
    connectivity: int = 8,
    max_iterations: int = 10_000,
) -> np.ndarray:
    """Grow one region from each seed over neighbouring pixels of similar value.

    A pixel joins a region when it touches it (4- or 8-connectivity) and its
    grey level (or colour: Euclidean distance in the image's colour space) is
    within ``tolerance`` of the reference value: the seed pixel's value
    (``criterion="seed"``, identical to a fixed-range flood fill) or the region's
    running mean (``criterion="mean"``, Adams & Bischof). Regions grow in
    lockstep, one ring per iteration, and never take a pixel another region owns;
    a free pixel touching several regions joins the closer of the largest and the
    smallest neighbouring label. Each ring is two whole-image dilations, so the cost
    is the number of rings times the image (a flat 2000x2000 image grown from one
    corner: 2,000 rings, about 100 s on one core; ``max_iterations`` bounds it).

    Parameters
    ----------
    image : uint8 (H, W) grey or (H, W, 3) colour.
    seeds : (N, 2) seed pixels as (x, y) (column, row); a seed on a pixel an earlier
        seed already holds grows nothing.
    tolerance : grey levels (or colour distance), in (0, 442] (442 > 255 sqrt(3),
        the largest colour distance).
    criterion : "mean" or "seed".
    connectivity : 4 or 8.
    max_iterations : cap on growth rings, 0 to 10_000_000; growth also stops at
        the first ring that adds nothing.

    Returns int32 (H, W) labels: region ``i + 1`` grew from ``seeds[i]``, 0 is
    unassigned.
    """
    image = check_image("image", image)
    pts = check_points("seeds", seeds)
    tolerance = check_range("tolerance", tolerance, 0.0, 442.0)
    if tolerance == 0:
        raise VisionError("argument 'tolerance': expected a number in (0, 442], got 0")
    check_choice("criterion", criterion, ("mean", "seed"))
    check_choice("connectivity", connectivity, (4, 8))
    max_iterations = check_int("max_iterations", max_iterations, 0, MAX_ITERATIONS)
    h, w = image.shape[:2]
    xy = np.rint(pts).astype(np.int64)
    if np.any((xy[:, 0] < 0) | (xy[:, 0] >= w) | (xy[:, 1] < 0) | (xy[:, 1] >= h)):
        raise VisionError(f"argument 'seeds': every seed must lie inside the {w}x{h} image")
    img = _as_float(image)
    labels = np.zeros((h, w), np.int32)
    n = len(xy)
    _, first = np.unique(xy[:, 1] * w + xy[:, 0], return_index=True)  # first seed on a pixel
    labels[xy[first, 1], xy[first, 0]] = first + 1
    sums = np.zeros((n, img.shape[2]), np.float64)
    counts = np.zeros(n, np.int64)
    sums[first] = img[xy[first, 1], xy[first, 0]]
    counts[first] = 1
    refs = sums / np.maximum(counts, 1)[:, None]
    kernel = cv2.getStructuringElement(
        cv2.MORPH_RECT if connectivity == 8 else cv2.MORPH_CROSS, (3, 3)
    )
    tol2 = float(tolerance) ** 2
    exact = np.float32 if n < 2**24 else np.float64
    for _ in range(max_iterations):
        added = False
        # a free pixel may touch several regions: try the largest and the smallest
        # neighbouring label (two regions meeting at one pixel is the common case);
        # labels are dilated as floats: float32 is exact below 2**24 labels, float64 above
        lab_f = labels.astype(exact)
        reach_hi = cv2.dilate(lab_f, kernel).astype(np.int32)
        cand = (labels == 0) & (reach_hi > 0)
        if not cand.any():
            break
        big = exact(n + 1)
        reach_lo = (big - cv2.dilate(np.where(labels > 0, big - lab_f, 0), kernel)).astype(
            np.int32
        )
        ys, xs = np.nonzero(cand)
        pix = img[ys, xs]
        lab_hi, lab_lo = reach_hi[ys, xs], reach_lo[ys, xs]
        d_hi = np.sum((pix - refs[lab_hi - 1]) ** 2, axis=1)
        d_lo = np.sum((pix - refs[lab_lo - 1]) ** 2, axis=1)
        lab = np.where(d_lo < d_hi, lab_lo, lab_hi)
        ok = np.minimum(d_lo, d_hi) <= tol2
        if ok.any():
            added = True
            ys, xs, lab = ys[ok], xs[ok], lab[ok]
            labels[ys, xs] = lab
            if criterion == "mean":
                np.add.at(sums, lab - 1, img[ys, xs])
                np.add.at(counts, lab - 1, 1)
                refs = sums / np.maximum(counts, 1)[:, None]
        if not added:
            break
    return labels


def _quadtree_leaves(img: np.ndarray, tolerance: float, min_size: int) -> np.ndarray:
    """Leaf id per pixel: blocks split until max - min <= tolerance or min_size."""
    h, w = img.shape[:2]
    size = 1 << int(np.ceil(np.log2(max(h, w, 1))))
    leaves = -np.ones((h, w), np.int64)
    next_id = 0
    stack = [(0, 0, size)]
    while stack:
        y, x, s = stack.pop()
        if y >= h or x >= w:
            continue
        block = img[y : y + s, x : x + s]
        rng = float((block.max(axis=(0, 1)) - block.min(axis=(0, 1))).max())
        if rng <= tolerance or s <= min_size:
            leaves[y : y + s, x : x + s] = next_id
            next_id += 1
        else:
            half = s // 2
            stack.extend([(y, x, half), (y, x + half, half), (y + half, x, half),
                          (y + half, x + half, half)])
    return leaves


def split_and_merge(
    image: np.ndarray, *, tolerance: float, min_size: int = 1, min_area: int = 1
) -> np.ndarray:
    """Split-and-merge segmentation (Horowitz & Pavlidis quadtree).

    Split: starting from the whole image (padded to a power of two), a block whose
    range (max - min over its pixels and channels) exceeds ``tolerance`` is cut into
    four quadrants, down to ``min_size`` pixels. Merge: adjacent leaves are joined
    (closest means first, union-find) whenever the joined region's range stays within
    ``tolerance``, so uniform parts become one region each while a high-contrast
    texture stays in small pieces.

    Parameters
    ----------
    image : uint8 (H, W) grey or (H, W, 3) colour.
    tolerance : homogeneity limit on the range, grey levels, 0 to 255.
    min_size : smallest block edge in pixels, a power of two from 1 to 65536.
    min_area : regions smaller than this (pixels, 0 to 2**31 - 1) are returned as 0.

    Returns int32 (H, W) labels 1..N, numbered by decreasing area; 0 where the
    region is smaller than ``min_area``. Cost grows with the number of leaves: a
    fully textured 640x480 image at ``min_size=1`` takes seconds (pure Python
    merge); use it on crops or with a larger ``min_size``.
    """
    image = check_image("image", image)
    tolerance = check_range("tolerance", tolerance, 0.0, 255.0)
    min_size = check_int("min_size", min_size, 1, MAX_BLOCK)
    if min_size & (min_size - 1):
        raise VisionError(f"argument 'min_size': expected a power of two from 1 to {MAX_BLOCK}, "
                          f"got {min_size!r}")
    min_area = check_int("min_area", min_area, 0, MAX_AREA)
    img = _as_float(image)
    leaves = _quadtree_leaves(img, tolerance, min_size)
    n = int(leaves.max()) + 1
    flat = leaves.ravel()
    counts = np.bincount(flat, minlength=n).astype(np.float64)
    chans = img.reshape(-1, img.shape[2])
    lo = np.full((n, img.shape[2]), np.inf)
    hi = np.full((n, img.shape[2]), -np.inf)
    np.minimum.at(lo, flat, chans)
    np.maximum.at(hi, flat, chans)
    sums = np.stack([np.bincount(flat, chans[:, c], minlength=n) for c in range(img.shape[2])], 1)
    # adjacent leaf pairs (4-neighbourhood), unique
    a = np.concatenate([leaves[:, :-1].ravel(), leaves[:-1, :].ravel()])
    b = np.concatenate([leaves[:, 1:].ravel(), leaves[1:, :].ravel()])
    diff = a != b
    pairs = np.unique(np.sort(np.stack([a[diff], b[diff]], 1), axis=1), axis=0)
    means = sums / counts[:, None]
    order = np.argsort(np.abs(means[pairs[:, 0]] - means[pairs[:, 1]]).max(axis=1), kind="stable")
    parent = np.arange(n)

    def find(i: int) -> int:
        root = i
        while parent[root] != root:
            root = parent[root]
        while parent[i] != root:
            parent[i], i = root, parent[i]
        return root

    lo_l, hi_l = lo.tolist(), hi.tolist()
    for p, q in pairs[order].tolist():
        rp, rq = find(p), find(q)
        if rp == rq:
            continue
        new_lo = [min(u, v) for u, v in zip(lo_l[rp], lo_l[rq], strict=True)]
        new_hi = [max(u, v) for u, v in zip(hi_l[rp], hi_l[rq], strict=True)]
        if max(h_ - l_ for h_, l_ in zip(new_hi, new_lo, strict=True)) <= tolerance:
            parent[rq] = rp
            lo_l[rp], hi_l[rp] = new_lo, new_hi
    roots = np.array([find(i) for i in range(n)])
    region = roots[leaves]
    uniq, inv, area = np.unique(region.ravel(), return_inverse=True, return_counts=True)
    rank = np.empty(len(uniq), np.int32)
    order_area = np.argsort(-area, kind="stable")
    rank[order_area] = np.arange(1, len(uniq) + 1, dtype=np.int32)
    rank[area < min_area] = 0
    return rank[inv].reshape(leaves.shape).astype(np.int32)
