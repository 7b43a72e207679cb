import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cell.errors import VisionError
from cell.vision.rle import (
    RunLength,
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
    import cv2

    from cell import sim
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


def _head(h, w, binary, n):
    import struct
    return b"RLE1" + struct.pack("<IIBI", h, w, binary, n)


_MASK = np.zeros((8, 8), bool)
_MASK[2:5, 3:7] = True


@pytest.mark.parametrize("data", [
    b"RLE1",  # no header
    b"RLE1" + bytes(8),  # a short header
    _head(2, 2, 1, 2),  # a mask's header, no first value
    _head(60000, 60000, 1, 2**32 - 1) + b"\0" + b"\1" * 64,  # 4e9 runs in 65 bytes
    _head(2, 2, 0, 2) + b"\x01\x02" + b"\xff" * 9 + b"\x01" + b"\x05",  # a 10-byte varint
    _head(2, 2, 0, 2) + b"\x01\x02" + b"\xff" * 10 + b"\x7f" + b"\x05",  # over-long varint
    rle_to_bytes(rle_encode(_MASK)) + b"junk",  # trailing bytes
    _head(2, 2, 0, 2) + b"\x01\x02" + b"\x02\x01",  # lengths 2 + 1, not 4
    _head(2, 2, 0, 1) + b"\x01" + b"\x80\x80\x80\x80\x10",  # one run of 2**32
    _head(2, 2, 2, 1) + b"\x01" + b"\x04",  # flags 2
    _head(2, 2, 1, 1) + b"\x07" + b"\x04",  # a mask whose first value is 7
    _head(2, 2, 0, 5) + b"\x01" * 10,  # more runs than pixels
    _head(60000, 60000, 0, 1) + b"\x01" + b"\x80\xa0\xa7\xb4\x0d",  # 3.6e9 pixels
])
def test_rle_from_bytes_refuses_malformed_data(data):
    with pytest.raises(VisionError, match="argument 'data'"):
        rle_from_bytes(data)


def _runs(shape, values, lengths, binary=False):
    from cell.vision.rle import RunLength
    return RunLength(shape, binary, np.asarray(values), np.asarray(lengths))


@pytest.mark.parametrize("rle", [
    "runs",
    _runs((2, 2), np.array([1, 2], np.uint8), [5, -1]),  # a negative length
    _runs((2, 2), np.array([1], np.uint8), [2, 2]),  # fewer values than lengths
    _runs((2, 2), np.array([1, 2], np.uint8), [2.5, 1.5]),  # fractional lengths
    _runs((-2, -2), np.array([1], np.uint8), [4]),  # a negative shape
    _runs((2, 2), np.array([300, 2], np.int64), [2, 2]),  # a value beyond uint8
    _runs((2, 2), np.array([0, 2], np.uint8), [2, 2], binary=True),  # a mask's value 2
    _runs((2, 2), np.array([1, 2], np.uint8), [2, 1]),  # lengths sum to 3
    _runs((60000, 60000), np.array([1], np.uint8), [60000 * 60000]),  # 3.6e9 pixels
])
@pytest.mark.parametrize("function", [rle_decode, rle_to_bytes])
def test_inconsistent_runs_are_refused(function, rle):
    with pytest.raises(VisionError, match="argument 'rle'"):
        function(rle)


@pytest.mark.parametrize("quality", [150, -5, np.nan, "90", 1e18, 50.7, True])
def test_coding_sizes_refuses_a_bad_jpeg_quality(quality):
    with pytest.raises(VisionError, match="argument 'jpeg_quality': .* 0 to 100"):
        coding_sizes(_MASK, jpeg_quality=quality)


def test_coding_sizes_bounds_the_array():
    with pytest.raises(VisionError, match="argument 'array': .* 4194304 pixels"):
        coding_sizes(np.zeros((2049, 2048), bool))


def test_a_mask_whose_runs_do_not_alternate_is_refused():
    """The byte form keeps a mask's first value only: runs 1, 1, 0 came back as 1, 0, 1."""
    runs = RunLength((2, 4), True, np.array([1, 1, 0], np.uint8), np.array([3, 1, 4], np.int64))
    for f in (rle_decode, rle_to_bytes):
        with pytest.raises(VisionError, match="must alternate 0 and 1; runs 0 and 1 are both 1"):
            f(runs)


def test_a_shape_of_numpy_int32_cannot_overflow_the_size_check():
    """65536 x 65536 in int32 wrapped to 0 pixels and passed; decoding then failed in numpy."""
    big = RunLength((np.int32(65536), np.int32(65536)), True, np.zeros(0, np.uint8),
                    np.zeros(0, np.int64))
    for f in (rle_decode, rle_to_bytes):
        with pytest.raises(VisionError, match="argument 'rle': shape must be two integers"):
            f(big)


def test_the_longest_run_round_trips_through_bytes():
    """One run of 2**28 pixels (the largest array, 16384 x 16384, all one value) needs a
    5-byte varint: it came back as 0 when the encoder stopped at 4 bytes."""
    side = 2**14
    rle = RunLength((side, side), True, np.zeros(1, np.uint8), np.array([side * side], np.int64))
    back = rle_from_bytes(rle_to_bytes(rle))
    assert back.shape == (side, side) and back.lengths.tolist() == [side * side]
