"""How the compiled driver (`twmr.master.driver`) holds kernel values in its float vectors: every
value comes back with its own type and bits, and one it cannot hold is named (no numba here)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pytest

from twmr.master.driver import Unsupported, flatten, rebuild, shape_of


class Inner(NamedTuple):
    gain: float
    code: int
    on: bool


class Table(NamedTuple):
    inner: Inner
    breakpoints: np.ndarray
    matrix: np.ndarray
    pair: tuple


def test_nested_tables_arrays_ints_and_bools_come_back_as_given() -> None:
    value = Table(Inner(-0.0, 3, True), np.array([0.1, 0.2, 1e300]),
                  np.arange(6.0).reshape(2, 3) / 7.0, (np.float64(2.5), 7))
    shape = shape_of(value)
    flat: list[float] = [42.0]  # the vector holds other blocks' values before this one
    flatten(value, shape, flat)
    back, end = rebuild(np.array(flat), 1, shape)
    assert end == len(flat)
    assert type(back) is Table and type(back.inner) is Inner
    assert back.inner == (0.0, 3, True) and np.signbit(back.inner.gain)
    assert type(back.inner.code) is int and type(back.inner.on) is bool
    assert np.array_equal(back.breakpoints, value.breakpoints)
    assert back.matrix.shape == (2, 3) and np.array_equal(back.matrix, value.matrix)
    assert back.pair == (2.5, 7) and type(back.pair[1]) is int


@pytest.mark.parametrize(("value", "named"), [
    ((1.0, 2j), "complex"),
    ((np.array([1, 2]),), "ndarray"),
    (("text",), "str"),
])
def test_a_value_the_vectors_cannot_hold_is_named(value: tuple, named: str) -> None:
    with pytest.raises(Unsupported, match=named):
        shape_of(value)


def test_a_namedtuple_that_is_not_importable_is_refused() -> None:
    class Local(NamedTuple):
        a: float

    with pytest.raises(Unsupported, match="Local"):
        shape_of(Local(1.0))
