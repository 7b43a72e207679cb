import cv2
import numpy as np
import pytest

from cell.errors import VisionError
from cell.vision.template import (
    best_match,
    match_ncc,
    match_sad,
    match_ssd,
    two_template_decision,
)

PX_PER_MM = 1.65


def _scene(seed=20):
    """Belt of flat 32 px tiles at many grey levels, a textured 24x24 patch (mean 150,
    std about 9) at (x=100, y=60)."""
    rng = np.random.default_rng(seed)
    tiles = rng.permutation(np.linspace(20, 235, 35)).reshape(5, 7).astype(np.float32)
    img = cv2.resize(tiles, (224, 160), interpolation=cv2.INTER_NEAREST)
    patch = cv2.GaussianBlur(rng.normal(150, 40, (24, 24)).astype(np.float32), (0, 0), 1.2)
    img[60:84, 100:124] = patch
    img += rng.normal(0, 1.0, img.shape).astype(np.float32)
    return img, img[60:84, 100:124].copy()


def test_sad_matches_brute_force_and_equals_ssd_on_binary_images():
    rng = np.random.default_rng(21)
    img = rng.integers(0, 256, (17, 19)).astype(np.uint8)
    tpl = img[4:9, 6:12].copy()
    ref = np.array([[np.abs(img[y:y + 5, x:x + 6].astype(int) - tpl).sum()
                     for x in range(19 - 6 + 1)] for y in range(17 - 5 + 1)])
    np.testing.assert_array_equal(match_sad(img, tpl), ref)
    b = (rng.random((30, 40)) < 0.5).astype(np.uint8)
    np.testing.assert_allclose(match_sad(b, b[3:10, 5:14]), match_ssd(b, b[3:10, 5:14]), atol=1e-3)


def test_ssd_of_uint8_images_is_exact_where_the_template_was_cut():
    """An exact match scores (about) 0 and every score is the integer sum within 2e-7 of
    its size (converted to float32 first, OpenCV's sums of squares cancelled: 32 off at
    the match, up to 9e-7 of the sum elsewhere)."""
    rng = np.random.default_rng(5)
    img = (rng.random((480, 640)) * 255).astype(np.uint8)
    tpl = img[200:264, 300:364].copy()
    scores = match_ssd(img, tpl)
    assert scores[200, 300] <= 1.0 and np.argmin(scores) == 200 * scores.shape[1] + 300
    for y, x in rng.integers(0, 400, (50, 2)):
        exact = float(((img[y:y + 64, x:x + 64].astype(np.int64) - tpl) ** 2).sum())
        assert abs(scores[y, x] - exact) <= 2e-7 * exact


def test_all_three_find_an_unchanged_patch():
    img, tpl = _scene()
    for method, fn in (("ssd", match_ssd), ("sad", match_sad), ("ncc", match_ncc)):
        m = best_match(fn(img, tpl), tpl.shape, method=method)
        assert (m.x, m.y) == (100, 60), method


@pytest.mark.parametrize(("a", "b"), [(0.5, -40), (0.5, 40), (1.5, -40), (1.5, 40), (0.7, 25)])
def test_ncc_peak_stays_put_under_gain_and_offset_while_ssd_sad_move(a, b):
    img, tpl = _scene()
    changed = a * img + b  # the scene under other lighting; the template is not re-cut
    ncc = best_match(match_ncc(changed, tpl), tpl.shape, method="ncc")
    ssd = best_match(match_ssd(changed, tpl), tpl.shape, method="ssd")
    sad = best_match(match_sad(changed, tpl), tpl.shape, method="sad")
    assert (ncc.x, ncc.y) == (100, 60) and ncc.score > 0.99
    assert (ssd.x, ssd.y) != (100, 60)
    assert (sad.x, sad.y) != (100, 60)


def test_gain_offset_sweep_ncc_never_moves():
    """The whole range a in 0.5..1.5, b in -40..40 (5 x 5 grid). SSD/SAD stay put only
    where the change leaves the patch almost as it was (a*150 + b near 150)."""
    img, tpl = _scene()
    moved = {"ssd": [], "sad": []}
    for a in np.linspace(0.5, 1.5, 5):
        for b in np.linspace(-40, 40, 5):
            changed = (a * img + b).astype(np.float32)
            ncc = best_match(match_ncc(changed, tpl), tpl.shape, method="ncc")
            assert (ncc.x, ncc.y) == (100, 60), (a, b)
            for method, fn in (("ssd", match_ssd), ("sad", match_sad)):
                m = best_match(fn(changed, tpl), tpl.shape, method=method)
                if (m.x, m.y) == (100, 60):
                    assert abs(a * 150 + b - 150) < 5, (method, a, b)
                else:
                    moved[method].append((a, b))
    assert len(moved["ssd"]) >= 20 and len(moved["sad"]) >= 20


def _part_image(kind, *, size=(70, 70), yaw_deg=0.0, seed=0, centre=None, belt=85):
    """Top view of a grey part on the belt, anti-aliased, with sensor noise."""
    rng = np.random.default_rng(seed)
    ss = 4
    h, w = size
    big = np.full((h * ss, w * ss), float(belt), np.float32)
    cx, cy = centre if centre is not None else ((w - 1) / 2, (h - 1) / 2)
    c = (round((cx + 0.5) * ss), round((cy + 0.5) * ss))
    mm = PX_PER_MM * ss
    if kind == "washer":
        cv2.circle(big, c, round(10 * mm), 190, -1)
        cv2.circle(big, c, round(5.25 * mm), belt, -1)
    elif kind == "hex_nut":
        ang = np.radians(yaw_deg) + np.arange(6) * np.pi / 3
        r = 8.5 / np.cos(np.pi / 6) * mm
        pts = np.stack([c[0] + r * np.cos(ang), c[1] + r * np.sin(ang)], 1)
        cv2.fillConvexPoly(big, np.rint(pts).astype(np.int32), 190)
        cv2.circle(big, c, round(5 * mm), belt, -1)
    img = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA) + rng.normal(0, 3, (h, w))
    return np.clip(img, 0, 255).astype(np.uint8)


def test_two_template_decision_tells_washer_from_hex_nut():
    tpl_a = _part_image("washer", size=(40, 40), seed=1)
    tpl_b = _part_image("hex_nut", size=(40, 40), seed=2)
    rng = np.random.default_rng(22)
    for i in range(6):
        centre = tuple(rng.uniform(25, 75, 2))
        washer = _part_image("washer", size=(100, 100), centre=centre, seed=10 + i)
        nut = _part_image("hex_nut", size=(100, 100), centre=centre, seed=20 + i,
                          yaw_deg=rng.uniform(-4, 4))
        empty = _part_image("none", size=(100, 100), seed=30 + i)
        assert two_template_decision(washer, tpl_a, tpl_b, threshold=0.7).label == "A"
        assert two_template_decision(nut, tpl_a, tpl_b, threshold=0.7).label == "B"
        assert two_template_decision(empty, tpl_a, tpl_b, threshold=0.7).label == "none"
    d = two_template_decision(washer, tpl_a, tpl_b)
    assert abs(d.match_a.centre[0] - centre[0]) <= 1 and abs(d.match_a.centre[1] - centre[1]) <= 1


def test_template_errors_name_the_argument():
    img = np.zeros((10, 10), np.uint8)
    with pytest.raises(VisionError, match="template.*larger"):
        match_ssd(img, np.zeros((12, 3), np.uint8))
    with pytest.raises(VisionError, match="template.*flat"):
        match_ncc(img, np.zeros((3, 3), np.uint8))
    with pytest.raises(VisionError, match="image"):
        match_sad(np.zeros((10, 10), np.int16), np.zeros((3, 3), np.uint8))
    with pytest.raises(VisionError, match="method.*valid"):
        best_match(np.zeros((3, 3), np.float32), (2, 2), method="mad")


def _rendered_parts(kind, placements, lightings, seed):
    """Grey overhead renders of steel ``kind`` parts; per lighting, per part: the
    image and the part's pixel centroid (from segmentation: scoring/teaching only)."""
    from cell.scenario import scenario_from_dict
    from cell.sim import World

    scenario = scenario_from_dict(
        {"seed": seed, "parts": {"count": len(placements), "kinds": [kind],
                                 "materials": ["steel"]}}
    )
    world = World.build(scenario, arm=False)
    ids = [world.place_next_part(x, y, yaw).id for x, y, yaw in placements]
    world.step(150)
    out = []
    for lighting in lightings:
        world.set_lighting(lighting)
        frame = world.render("overhead", depth=False, seg=True)
        grey = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2GRAY)
        for i in ids:
            ys, xs = np.nonzero(frame.seg == i)
            out.append((lighting, grey, (int(round(xs.mean())), int(round(ys.mean())))))
    world.close()
    return out


def test_two_template_decision_on_rendered_washer_and_disc():
    """Teach one washer and one disc (61 px templates cut at the part centre), then
    decide on windows around parts at other places, yaws and lightings."""
    from cell.sim import layout

    y0 = layout.CONVEYOR_Y
    templates = {}
    for kind in ("washer", "disc"):
        (_, grey, (cx, cy)), = _rendered_parts(kind, [(0.0, y0, 0.0)], ["front"], seed=1)
        templates[kind] = grey[cy - 30 : cy + 31, cx - 30 : cx + 31].copy()
    places = [(-0.1, y0 - 0.02, 0.5), (0.05, y0 + 0.02, 2.0)]
    for kind, label in (("washer", "A"), ("disc", "B")):
        for lighting, grey, (cx, cy) in _rendered_parts(kind, places, ["front", "coaxial", "warm"],
                                                        seed=7):
            window = grey[cy - 50 : cy + 50, cx - 50 : cx + 50]
            d = two_template_decision(window, templates["washer"], templates["disc"],
                                      threshold=0.7)
            assert d.label == label, (kind, lighting, d.score_a, d.score_b)
            assert max(d.score_a, d.score_b) > 0.85
    empty = np.ascontiguousarray(grey[200:300, 5:105])  # belt only
    assert two_template_decision(empty, templates["washer"], templates["disc"]).label == "none"


def _nan_at(a, value=np.nan):
    a = a.astype(np.float32)
    a[3, 3] = value
    return a


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("fn", [match_ssd, match_sad, match_ncc])
def test_a_nan_or_inf_pixel_is_refused_not_a_perfect_match(fn, value):
    img, tpl = _scene()
    with pytest.raises(VisionError, match="argument 'image'.*finite"):
        fn(_nan_at(img, value), tpl)
    with pytest.raises(VisionError, match="argument 'template'.*finite"):
        fn(img, _nan_at(tpl, value))


def test_two_template_decision_names_the_template_and_refuses_nan():
    img, tpl = _scene()
    with pytest.raises(VisionError, match="argument 'template_a'"):
        two_template_decision(img, "T", tpl)
    with pytest.raises(VisionError, match="argument 'template_b'.*flat"):
        two_template_decision(img, tpl, np.zeros((5, 5), np.float32))
    with pytest.raises(VisionError, match="argument 'template_b'.*finite"):
        two_template_decision(img, tpl, _nan_at(tpl))
    with pytest.raises(VisionError, match="argument 'image'.*finite"):
        two_template_decision(_nan_at(img), tpl, tpl[::-1].copy())


@pytest.mark.parametrize(
    ("kw", "name"),
    [({"threshold": np.nan}, "threshold"), ({"threshold": 5.0}, "threshold"),
     ({"threshold": -0.1}, "threshold"), ({"threshold": "0.7"}, "threshold"),
     ({"margin": np.nan}, "margin"), ({"margin": -5}, "margin"), ({"margin": 2.5}, "margin"),
     ({"margin": True}, "margin")],
)
def test_two_template_decision_checks_threshold_and_margin(kw, name):
    img, tpl = _scene()
    with pytest.raises(VisionError, match=f"argument '{name}'"):
        two_template_decision(img, tpl, tpl[::-1].copy(), **kw)


@pytest.mark.parametrize(
    "shape", ["ab", (16,), (np.nan, 16), (-16, 16), (16, 1e18), (16.0, 16), (0, 4), None]
)
def test_best_match_checks_template_shape(shape):
    scores = np.zeros((5, 5), np.float32)
    with pytest.raises(VisionError, match="argument 'template_shape'"):
        best_match(scores, shape, method="ssd")


def test_best_match_refuses_nan_scores():
    scores = np.ones((5, 5), np.float32)
    scores[2, 2] = np.nan
    with pytest.raises(VisionError, match="argument 'scores'.*finite"):
        best_match(scores, (3, 3), method="ncc")


def test_match_sad_refuses_work_beyond_its_bound():
    img = np.zeros((2000, 2000), np.uint8)
    with pytest.raises(VisionError, match="argument 'template'.*2\\*\\*32"):
        match_sad(img, img[:200, :200])


def test_best_match_centre_of_a_non_square_template():
    """centre = top-left + ((w - 1) / 2, (h - 1) / 2): x goes with the width."""
    scores = np.ones((20, 30), np.float32)
    scores[5, 3] = 0.0
    m = best_match(scores, (4, 10), method="ssd")
    assert (m.x, m.y) == (3, 5)
    assert m.centre == (3 + 4.5, 5 + 1.5)


def _two_templates():
    rng = np.random.default_rng(3)
    img = rng.integers(0, 255, (40, 60)).astype(np.uint8)
    return img, img[5:20, 5:20].copy(), img[20:35, 30:45].copy()


def test_two_template_decision_needs_both_threshold_and_margin():
    img, tpl_a, tpl_b = _two_templates()
    # the same template twice: both peak at 1.0, above the threshold but no lead
    tie = two_template_decision(img, tpl_a, tpl_a.copy())
    assert tie.score_a == tie.score_b and tie.label == "none"
    # a lead of exactly the margin wins ("at least margin")
    d = two_template_decision(img, tpl_a, tpl_b, threshold=0.5, margin=0.0)
    lead = abs(d.score_a - d.score_b)
    assert lead > 0 and d.label in ("A", "B")
    assert two_template_decision(img, tpl_a, tpl_b, threshold=0.5, margin=lead).label == d.label


def test_match_sad_refuses_work_just_beyond_its_bound():
    """65536 template pixels x 65537 placements is just over 2**32: refused at once."""
    img = np.zeros((1, 2 * 65536), np.uint8)
    with pytest.raises(VisionError, match="2\\*\\*32"):
        match_sad(img, img[:, :65536])
