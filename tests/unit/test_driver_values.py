"""How the compiled driver (`twmr.master.driver`) holds kernel values in its float vectors: every
value comes back with its own type and bits, and one it cannot hold is named (no numba here)."""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
import pytest

from twmr.master.driver import Unsupported, flatten, kind_of, rebuild, shape_of


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


@pytest.mark.parametrize(("value", "shape"), [
    (1.5, "f"), (np.float64(1.5), "f"), (3, "i"), (np.int64(3), "i"), (True, "b"),
    (np.bool_(False), "b"), (np.int32(3), "i"), ((), ("t", None, ())),
    ((1.0, (2, True)), ("t", None, ("f", ("t", None, ("i", "b"))))),
    (Inner(1.0, 2, False), ("t", Inner, ("f", "i", "b"))),
])
def test_each_value_has_the_shape_of_its_type(value: object, shape: object) -> None:
    assert shape_of(value) == shape


def test_a_scalar_of_another_float_type_is_refused() -> None:
    with pytest.raises(Unsupported, match="float32"):
        shape_of((1.0, np.float32(2.0)))


def test_equal_kinds_are_one_object_and_a_changed_value_shape_is_another_kind() -> None:
    from twmr.blocks.linear import Gain
    from twmr.core.kernel import Kernel

    comp = Gain("g", k=2.0)
    kern = comp.kernel(1e-3)
    assert isinstance(kern, Kernel)
    first = kind_of(comp, kern)
    again = kind_of(comp, Gain("g2", k=3.0).kernel(1e-3))
    assert again is first and again.key is first.key
    plain = kind_of(comp, dataclasses.replace(kern, params=(2.0,)))  # no NamedTuple
    ints = kind_of(comp, dataclasses.replace(kern, params=(2,)))
    assert len({id(first), id(plain), id(ints)}) == 3
    assert len({first.key, plain.key, ints.key}) == 3


def test_a_value_comes_back_the_same_from_the_vector_and_from_its_list() -> None:
    value = Table(Inner(-0.0, 3, True), np.array([0.1, np.nan, 1e300]),
                  np.arange(6.0).reshape(3, 2) / 7.0, (np.float64(2.5), 7))
    shape = shape_of(value)
    flat: list[float] = []
    flatten(value, shape, flat)
    vec = np.array(flat)
    (a, end_a), (b, end_b) = rebuild(vec, 0, shape), rebuild(vec.tolist(), 0, shape)
    assert end_a == end_b == len(flat) and type(a) is type(b) is Table
    assert a.inner == b.inner and np.signbit(b.inner.gain) and type(b.inner.code) is int
    for x, y in ((a.breakpoints, b.breakpoints), (a.matrix, b.matrix)):
        assert x.shape == y.shape and x.dtype == y.dtype == np.float64
        assert x.tobytes() == y.tobytes()
    assert a.pair == b.pair == (2.5, 7) and type(b.pair[0]) is float


def test_a_kind_has_the_widths_of_its_outputs_states_and_inputs_in_declared_order() -> None:
    from twmr.blocks.linear import Gain
    from twmr.core.port import Input, Output, State

    class Wide(Gain):
        v = Input(size=3)
        w = State(size=2)
        z = Output(0.0)

    comp = Wide("w", k=2.0)
    kind = kind_of(comp, comp.kernel(1e-3))
    widths = {n: None if v.size is None else v.width for n, v in comp.variables.items()}
    assert kind.outputs == tuple(widths[n] for n in comp.outputs) == (None, 2, None)
    assert kind.inputs == tuple(widths[n] for n in comp.inputs) == (None, 3)
