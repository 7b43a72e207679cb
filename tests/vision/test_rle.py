import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cell.errors import VisionError
from cell.vision.rle import (
    coding_sizes,
    rle_decode,
    rle_encode,
    rle_from_bytes,
    rle_to_bytes,
)

shapes = st.tuples(st.integers(1, 40), st.integers(1, 40))
shapes_with_empty = st.tuples(st.integers(0, 40), st.integers(0, 40))


@settings(max_examples=200, deadline=None)
@given(arrays(np.bool_, shapes))
def test_mask_round_trip_is_lossless(mask):
    rle = rle_encode(mask)
    assert int(rle.lengths.sum()) == mask.size
    back = rle_decode(rle)
    assert back.dtype == np.bool_
    np.testing.assert_array_equal(back, mask)
    np.testing.assert_array_equal(rle_decode(rle_from_bytes(rle_to_bytes(rle))), mask)


@settings(max_examples=100, deadline=None)
@given(arrays(np.uint8, shapes, elements=st.integers(0, 3)), st.integers(1, 6))
def test_image_round_trip_is_lossless_with_long_runs(img, repeat):
    img = np.repeat(img, repeat * 50, axis=1)  # runs beyond 127 need multi-byte varints
    data = rle_to_bytes(rle_encode(img))
    back = rle_decode(rle_from_bytes(data))
    assert back.dtype == np.uint8
    np.testing.assert_array_equal(back, img)


def _round_trip(array):
    return rle_decode(rle_from_bytes(rle_to_bytes(rle_encode(array))))


@settings(max_examples=200, deadline=None)
@given(st.one_of(arrays(np.bool_, shapes_with_empty),
                 arrays(np.uint8, shapes_with_empty, elements=st.integers(0, 2))))
def test_round_trip_through_bytes_includes_empty_shapes(array):
    back = _round_trip(array)
    assert back.dtype == array.dtype
    assert back.shape == array.shape
    np.testing.assert_array_equal(back, array)


@pytest.mark.parametrize("shape", [(0, 5), (5, 0), (0, 0)])
@pytest.mark.parametrize("dtype", [np.bool_, np.uint8])
def test_empty_array_round_trips_as_a_header_alone(shape, dtype):
    empty = np.zeros(shape, dtype)
    rle = rle_encode(empty)
    assert rle.values.size == rle.lengths.size == 0
    data = rle_to_bytes(rle)
    assert len(data) == 17  # header only: no value byte, no lengths
    back = rle_decode(rle_from_bytes(data))
    assert back.shape == shape
    assert back.dtype == dtype


def test_worked_example():
    mask = np.array([[0, 0, 1, 1, 1], [1, 0, 0, 0, 0]], bool)
    rle = rle_encode(mask)
    assert rle.values.tolist() == [0, 1, 0]
    assert rle.lengths.tolist() == [2, 4, 4]
    # header 17 bytes + first value + three one-byte lengths
    assert len(rle_to_bytes(rle)) == 17 + 1 + 3


@pytest.fixture(scope="module")
def rendered():
    sim = pytest.importorskip("cell.sim")
    import cv2

    from cell.scenario import scenario_from_dict
    from cell.sim import layout

    world = sim.World.build(scenario_from_dict({"seed": 5, "parts": {"count": 3}}), arm=False)
    for x in (-0.06, 0.0, 0.06):
        world.place_next_part(x, layout.CONVEYOR_Y, 0.5)
    world.step(50)
    frame = world.render("overhead", depth=False, seg=True)
    world.close()
    return frame.seg > 0, cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2GRAY)


def test_sizes_beside_png_and_jpeg_on_a_rendered_mask_and_image(rendered):
    mask, grey = rendered
    assert mask.any()
    m = coding_sizes(mask)
    g = coding_sizes(grey)
    print(f"mask 640x480: raw {m.raw} B, RLE {m.rle} B, PNG {m.png} B, "
          f"JPEG q{m.jpeg_quality} {m.jpeg} B ({m.jpeg_wrong} wrong pixels)")
    print(f"grey image: raw {g.raw} B, RLE {g.rle} B, PNG {g.png} B, JPEG {g.jpeg} B "
          f"({g.jpeg_wrong} changed pixels)")
    np.testing.assert_array_equal(rle_decode(rle_encode(mask)), mask)
    assert m.rle < m.raw / 10  # a sparse mask: runs beat the 1-bit bitmap by far
    assert m.rle < m.png  # and PNG's container overhead
    assert m.jpeg_wrong > 0 or m.jpeg > m.rle  # JPEG is lossy on edges, or larger
    assert g.rle > g.png  # a noisy camera image has short runs: RLE loses to PNG


def test_rle_errors_name_the_argument():
    with pytest.raises(VisionError, match="array"):
        rle_encode(np.zeros((2, 2), np.float32))
    with pytest.raises(VisionError, match="data"):
        rle_from_bytes(b"nope")
