import cv2
import numpy as np
import pytest

from cell.errors import VisionError
from cell.vision.regions import region_grow, split_and_merge


def _textured_belt(seed=8):
    """A belt with per-pixel texture 40..200 and three uniform parts at grey 115..130."""
    rng = np.random.default_rng(seed)
    h, w = 96, 128
    img = rng.integers(40, 201, (h, w)).astype(np.float64)
    truth = []
    for (x, y, s), level in zip([(10, 12, 30), (60, 20, 24), (30, 60, 28)], (118, 124, 130),
                                strict=True):
        m = np.zeros((h, w), bool)
        m[y : y + s, x : x + s] = True
        img[m] = level + rng.integers(-3, 4, m.sum())
        truth.append(m)
    return img.astype(np.uint8), truth


def _iou(a, b):
    return (a & b).sum() / (a | b).sum()


def test_no_global_threshold_finds_the_parts():
    img, truth = _textured_belt()
    union = np.logical_or.reduce(truth)
    best = max(max(_iou(img > t, union), _iou(img <= t, union)) for t in range(256))
    assert best < 0.4


@pytest.mark.parametrize("criterion", ["mean", "seed"])
def test_region_growing_finds_parts_on_textured_belt(criterion):
    img, truth = _textured_belt()
    seeds = [np.argwhere(m).mean(axis=0)[::-1] for m in truth]
    labels = region_grow(img, np.array(seeds), tolerance=10, criterion=criterion, connectivity=4)
    for i, m in enumerate(truth):
        assert _iou(labels == i + 1, m) > 0.85


def test_region_growing_seed_criterion_equals_fixed_range_flood_fill():
    rng = np.random.default_rng(9)
    img = cv2.GaussianBlur(rng.integers(0, 256, (60, 70)).astype(np.uint8), (7, 7), 2)
    seed = (35, 30)
    labels = region_grow(img, np.array([seed]), tolerance=6.5, criterion="seed", connectivity=4)
    ff = np.zeros((62, 72), np.uint8)
    cv2.floodFill(img.copy(), ff, seed, 255, 6, 6, 4 | cv2.FLOODFILL_FIXED_RANGE
                  | cv2.FLOODFILL_MASK_ONLY | (1 << 8))
    np.testing.assert_array_equal(labels == 1, ff[1:-1, 1:-1] > 0)


def test_region_growing_on_colour():
    img = np.zeros((40, 40, 3), np.uint8)
    img[:] = (30, 90, 200)
    img[10:30, 10:30] = (200, 40, 40)
    labels = region_grow(img, np.array([[20, 20], [2, 2]]), tolerance=20)
    assert (labels == 1).sum() == 400 and (labels == 2).sum() == 1600 - 400


def test_split_and_merge_finds_parts_on_textured_belt():
    img, truth = _textured_belt()
    labels = split_and_merge(img, tolerance=12, min_area=200)
    regions = [labels == k for k in range(1, labels.max() + 1)]
    assert len(regions) == 3  # the texture stays in pieces smaller than min_area
    for m in truth:
        assert max(_iou(r, m) for r in regions) > 0.85


def test_region_errors_name_the_argument():
    img = np.zeros((10, 10), np.uint8)
    with pytest.raises(VisionError, match="seeds"):
        region_grow(img, np.array([[20, 2]]), tolerance=5)
    with pytest.raises(VisionError, match="criterion"):
        region_grow(img, np.array([[2, 2]]), tolerance=5, criterion="max")
    with pytest.raises(VisionError, match="min_size"):
        split_and_merge(img, tolerance=5, min_size=3)


@pytest.mark.parametrize(("name", "value"), [
    ("tolerance", np.nan), ("tolerance", 0), ("tolerance", -1), ("tolerance", "5"),
    ("tolerance", np.inf), ("tolerance", 1e6), ("max_iterations", -1), ("max_iterations", 2.5),
    ("max_iterations", np.nan), ("max_iterations", "9"), ("max_iterations", True),
    ("max_iterations", 10**12),
])
def test_region_grow_refuses_bad_numbers(name, value):
    img = np.zeros((10, 10), np.uint8)
    kw = {"tolerance": 5, name: value}
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        region_grow(img, np.array([[2, 2]]), **kw)


@pytest.mark.slow  # 2**24 seeds: about 2.5 s and 850 MB
def test_region_grow_labels_beyond_float32_precision_stay_exact():
    # 2**24 + 3 seeds (all but the last on one pixel): the last label is not a float32
    img = np.full((8, 8), 100, np.uint8)
    img[0, 0] = 0
    seeds = np.zeros((2**24 + 3, 2))
    seeds[-1] = (5, 5)
    labels = region_grow(img, seeds, tolerance=5)
    assert labels[0, 0] == 1 and (labels.ravel()[1:] == 2**24 + 3).all()


@pytest.mark.parametrize("criterion", ["mean", "seed"])
@pytest.mark.parametrize("connectivity", [4, 8])
def test_region_grow_seed_criterion_is_a_flood_fill(criterion, connectivity):
    rng = np.random.default_rng(3)
    img = cv2.GaussianBlur(rng.integers(0, 256, (40, 50)).astype(np.uint8), (7, 7), 3)
    labels = region_grow(img, np.array([[25, 20]]), tolerance=6, criterion=criterion,
                         connectivity=connectivity)
    flood = np.zeros((42, 52), np.uint8)
    cv2.floodFill(img.copy(), flood, (25, 20), 0, 6, 6,
                  connectivity | cv2.FLOODFILL_FIXED_RANGE | cv2.FLOODFILL_MASK_ONLY | (1 << 8))
    region = labels == 1
    if criterion == "seed":
        assert np.array_equal(region, flood[1:-1, 1:-1] > 0)
        return
    # the running mean: one connected region holding the seed, its growth
    # stopped where every free pixel touching it is beyond tolerance of its final mean
    count, _ = cv2.connectedComponents(region.astype(np.uint8), connectivity=connectivity)
    assert region[20, 25] and count == 2 and region.sum() > 1
    kernel = np.ones((3, 3), np.uint8) if connectivity == 8 else cv2.getStructuringElement(
        cv2.MORPH_CROSS, (3, 3))
    frontier = (cv2.dilate(region.astype(np.uint8), kernel) > 0) & ~region & (labels == 0)
    mean = img[region].mean()
    assert frontier.any() and (np.abs(img[frontier] - mean) > 6 - 1e-6).all()


@pytest.mark.parametrize(("name", "value"), [
    ("tolerance", np.nan), ("tolerance", -1), ("tolerance", "5"), ("tolerance", 256),
    ("min_size", 2.0), ("min_size", np.nan), ("min_size", "2"), ("min_size", 0),
    ("min_size", 2**20), ("min_area", np.nan), ("min_area", -4), ("min_area", "3"),
    ("min_area", 2**31),
])
def test_split_and_merge_refuses_bad_numbers(name, value):
    img = np.zeros((10, 10), np.uint8)
    kw = {"tolerance": 5, name: value}
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        split_and_merge(img, **kw)


def test_split_and_merge_keeps_a_region_of_exactly_min_area():
    """Regions smaller than min_area are 0; one of exactly min_area pixels is kept."""
    img = np.zeros((16, 16), np.uint8)
    img[4:8, 4:8] = 200  # 16 pixels
    kept = split_and_merge(img, tolerance=10, min_area=16)
    assert kept.max() == 2 and np.all(kept[4:8, 4:8] == 2)
    dropped = split_and_merge(img, tolerance=10, min_area=17)
    assert np.all(dropped[4:8, 4:8] == 0) and dropped[0, 0] == 1
