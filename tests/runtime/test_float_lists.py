"""A message's list of numbers as an array (:mod:`facesynth.runtime.float_lists`): bit for bit
what ``np.asarray(values, dtype=np.float64)`` gave, and numpy's own error where it refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from facesynth.runtime.float_lists import float64_array

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(width=32),
    st.integers(-(2**62), 2**62),
    st.booleans(),
)


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@settings(max_examples=300, deadline=None)
@given(st.lists(numbers, max_size=200))
def test_any_list_of_numbers_gives_numpys_array_bit_for_bit(values: list[float]) -> None:
    assert same_bits(float64_array(values), np.asarray(values, dtype=np.float64))


def test_a_face_mesh_of_float32_values_and_the_special_values() -> None:
    mesh = (np.random.default_rng(3).random((478, 3), dtype=np.float32) * 640).ravel().tolist()
    special = [math.nan, -math.nan, math.inf, -math.inf, -0.0, 5e-324, 1.7976931348623157e308]
    for values in (mesh, special, [], [np.float32(0.1), np.float64(0.2), 3]):
        assert same_bits(float64_array(values), np.asarray(values, dtype=np.float64))


def test_the_array_is_new_and_writable() -> None:
    values = [1.0, 2.0, 3.0]
    array = float64_array(values)
    array[0] = 9.0
    assert array.tolist() == [9.0, 2.0, 3.0] and values == [1.0, 2.0, 3.0]


@pytest.mark.parametrize("values", [["1.5", 2.0], [1.0, [2.0]], [1.0, None], [10**400]], ids=str)
def test_what_struct_will_not_pack_gets_numpys_answer(values: list[object]) -> None:
    try:
        expected: object = np.asarray(values, dtype=np.float64)
    except Exception as exc:
        with pytest.raises(type(exc)) as raised:
            float64_array(values)  # type: ignore[arg-type]
        assert str(raised.value) == str(exc)
    else:
        assert isinstance(expected, np.ndarray)
        assert same_bits(float64_array(values), expected)  # type: ignore[arg-type]
