"""Printing what a user wrote: ``cell.text.escape`` and ``show`` (properties), and the
checks that echo a value through them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cell.camera import CameraModel
from cell.errors import CalibrationError, VisionError
from cell.text import escape, override_source, show
from cell.vision._checks import check_int, check_odd


@given(st.text())
def test_escape_is_printable_and_idempotent(text):
    out = escape(text)
    assert out.isprintable()
    assert escape(out) == out


@given(st.text(alphabet=st.characters(blacklist_categories=("Cc", "Cs", "Zl", "Zp", "Co", "Cn"))))
def test_escape_leaves_printable_text_alone(text):
    if text.isprintable():
        assert escape(text) == text


@given(st.one_of(st.text(), st.integers(), st.floats(), st.lists(st.text()), st.binary()),
       st.integers(4, 200))
def test_show_is_printable_and_short(value, limit):
    out = show(value, limit)
    assert out.isprintable()
    assert len(out) <= max(limit, 30)  # an integer too long is named by its digits


def test_show_names_an_integer_too_long_to_print():
    assert show(10**5000) == "an integer of 5001 digits"
    assert show([10**5000]) == "a list too large to show"


def test_override_source_is_escaped_and_cut():
    out = override_source("a=\x1b[2J" + "x" * 500)
    assert out.startswith("--set a=\\x1b[2J") and len(out) <= 106 and out.endswith("...")


def test_vision_checks_name_a_huge_integer():  # repr() of it raised ValueError
    with pytest.raises(VisionError, match="5001 digits"):
        check_int("size", 10**5000, 0, 10)
    with pytest.raises(VisionError, match="5001 digits"):
        check_odd("block_size", 10**5000)


def test_camera_model_names_a_huge_integer():
    with pytest.raises(CalibrationError, match="'width'.*5001 digits"):
        CameraModel(width=10**5000, height=480, K=np.eye(3), dist=np.zeros(5),
                    T_world_camera=np.eye(4))
