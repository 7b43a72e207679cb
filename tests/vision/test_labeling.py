import numpy as np
import pytest
from skimage.measure import label as sk_label

from cell.errors import VisionError
from cell.vision.labeling import label_components


def test_diagonal_chain_is_one_region_under_8_and_many_under_4():
    mask = np.eye(6, dtype=bool)
    assert label_components(mask, connectivity=8).count == 1
    four = label_components(mask, connectivity=4)
    assert four.count == 6
    assert np.all(four.areas == 1)


def test_stats_area_bbox_centroid():
    mask = np.zeros((20, 30), bool)
    mask[2:6, 3:10] = True  # 4 x 7
    mask[12:19, 20:23] = True  # 7 x 3
    c = label_components(mask)
    assert c.count == 2
    assert sorted(c.areas.tolist()) == [21, 28]
    i = int(np.argmax(c.areas))
    assert c.bboxes[i].tolist() == [3, 2, 7, 4]
    np.testing.assert_allclose(c.centroids[i], [6.0, 3.5])
    assert c.mask(i + 1).sum() == 28


@pytest.mark.parametrize("conn", [4, 8])
def test_counts_match_scikit_image(conn):
    rng = np.random.default_rng(7)
    mask = rng.random((80, 90)) < 0.45
    ours = label_components(mask, connectivity=conn)
    ref = sk_label(mask, connectivity=1 if conn == 4 else 2)
    assert ours.count == ref.max()
    # same partition: each of our regions maps to exactly one reference region
    pairs = np.unique(np.stack([ours.labels[mask], ref[mask]]), axis=1)
    assert pairs.shape[1] == ours.count


def test_min_area_drops_small_regions_and_renumbers():
    mask = np.zeros((10, 10), bool)
    mask[0, 0] = True
    mask[5:9, 5:9] = True
    c = label_components(mask, min_area=2)
    assert c.count == 1 and c.areas.tolist() == [16]
    assert set(np.unique(c.labels)) == {0, 1}
    assert label_components(mask, min_area=16).areas.tolist() == [16]  # exactly min_area: kept
    assert label_components(mask, min_area=17).count == 0


def test_bad_connectivity_is_named():
    with pytest.raises(VisionError, match="connectivity.*valid"):
        label_components(np.zeros((3, 3), bool), connectivity=6)


@pytest.mark.parametrize(
    ("kw", "name"),
    [({"connectivity": 4.0}, "connectivity"), ({"connectivity": True}, "connectivity"),
     ({"min_area": np.nan}, "min_area"), ({"min_area": -5}, "min_area"),
     ({"min_area": "5"}, "min_area"), ({"min_area": 2.0}, "min_area"),
     ({"min_area": 2**31}, "min_area")],
)
def test_numbers_are_checked(kw, name):
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        label_components(np.ones((3, 3), bool), **kw)


def test_min_area_limits_are_accepted():
    mask = np.ones((3, 3), bool)
    assert label_components(mask, min_area=9).count == 1
    assert label_components(mask, min_area=0).count == 1
    assert label_components(mask, min_area=2**31 - 1).count == 0
