"""The public RLE (spec §1.5): alternating runs from zeros, row-major, last run written."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from po3d_ppl.errors import InputError
from po3d_ppl.world import rle


def reference_encode(flat: list[int]) -> str:
    """Straightforward run counting as the public format defines it (independent of the numpy codec)."""
    runs, current, length = [], 0, 0
    for value in flat:
        if value == current:
            length += 1
        else:
            runs.append(length)
            current, length = 1 - current, 1
    runs.append(length)
    return ",".join(map(str, runs))


def test_conventions_on_small_examples():
    assert rle.encode(np.zeros((2, 3), bool)) == "6"
    assert rle.encode(np.ones((2, 3), bool)) == "0,6"  # first run counts zeros, even when there are none
    assert rle.encode(np.array([[0, 1, 1], [0, 0, 1]], bool)) == "1,2,2,1"  # row-major
    assert rle.encode(np.array([[1, 0, 0], [0, 0, 0]], bool)) == "0,1,5"


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 9), st.integers(1, 9), st.data())
def test_round_trip_and_reference(h, w, data):
    bits = data.draw(st.lists(st.integers(0, 1), min_size=h * w, max_size=h * w))
    mask = np.array(bits, dtype=bool).reshape(h, w)
    text = rle.encode(mask)
    assert text == reference_encode(bits)
    assert text == rle.encode_indices(np.flatnonzero(mask), h * w)
    assert np.array_equal(rle.decode(text, h, w), mask)
    assert rle.count(text) == int(mask.sum())
    assert sum(int(t) for t in text.split(",")) == h * w


def test_bbox_is_public_xywh_with_exclusive_end():
    mask = np.zeros((6, 8), bool)
    mask[2:4, 3:7] = True
    assert rle.bbox_of(mask) == (3, 2, 4, 2)
    assert rle.bbox_of(np.zeros((6, 8), bool)) == (0, 0, 0, 0)


@pytest.mark.parametrize("bad", ["", "1,a", "3,-1,2", None])
def test_malformed_strings_raise_input_error(bad):
    with pytest.raises(InputError):
        rle.decode(bad, 1, 4)


def test_decode_checks_total():
    with pytest.raises(InputError, match="expected 2x3"):
        rle.decode("2,3", 2, 3)
