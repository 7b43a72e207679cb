import numpy as np
import pytest

from cell.errors import VisionError
from cell.vision.pixel import invert, quantize


def test_invert_syllabus_values():
    img = np.array([[0, 200], [255, 55]], dtype=np.uint8)
    out = invert(img)
    assert out.tolist() == [[255, 55], [0, 200]]
    assert out.dtype == np.uint8


def test_invert_twice_is_identity_on_colour():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (8, 9, 3), dtype=np.uint8)
    np.testing.assert_array_equal(invert(invert(img)), img)


@pytest.mark.parametrize("bits", range(1, 9))
def test_quantize_to_n_bits(bits):
    img = np.arange(256, dtype=np.uint8).reshape(16, 16)
    out = quantize(img, bits=bits)
    levels = np.unique(out)
    assert len(levels) == 2**bits
    step = 2 ** (8 - bits)
    assert np.all(levels % step == 0)
    err = img.astype(int) - out
    assert err.min() == 0 and err.max() == step - 1
    centred = quantize(img, bits=bits, centre=True).astype(int)
    assert np.abs(img - centred).max() <= max(step // 2, 0)


def test_quantize_rejects_bad_input():
    with pytest.raises(VisionError, match="bits"):
        quantize(np.zeros((2, 2), np.uint8), bits=0)
    with pytest.raises(VisionError, match="image"):
        quantize(np.zeros((2, 2), np.float64), bits=4)
    with pytest.raises(VisionError, match="image"):
        invert(np.zeros((2, 2, 4), np.uint8))


@pytest.mark.parametrize("bits", [True, 4.0, "4", np.nan, 9])
def test_quantize_refuses_bits_that_are_not_an_integer_in_1_to_8(bits):
    with pytest.raises(VisionError, match="argument 'bits': expected an integer from 1 to 8"):
        quantize(np.zeros((2, 2), np.uint8), bits=bits)


@pytest.mark.parametrize("centre", ["no", 1, None])
def test_quantize_refuses_a_centre_that_is_not_a_bool(centre):
    with pytest.raises(VisionError, match="argument 'centre'"):
        quantize(np.zeros((2, 2), np.uint8), bits=3, centre=centre)
