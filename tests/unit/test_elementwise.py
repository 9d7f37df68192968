"""`twmr.core.elementwise`: one scalar kernel function applied to every element of the tuples
among its arguments, the same values from plain Python and from numba, scalars passed whole."""
from __future__ import annotations

import math
from typing import NamedTuple

import pytest

from twmr.core.elementwise import elementwise
from twmr.core.kernel import kernel_function


class P(NamedTuple):
    a: float
    b: float


@elementwise
def affine(u: float, v: float, p: P) -> float:
    return p.a * u + p.b * math.sin(v)


@kernel_function
def call(u: object, v: object, p: P) -> object:
    return affine(u, v, p)


@pytest.mark.parametrize(("u", "v"), [
    (0.5, 2.0), ((0.5,), (2.0,)), ((1.0, -2.0, 3.5), (0.1, 0.2, 0.3)), ((1.0, 2.0, 3.0, 4.0), 0.7),
])
def test_python_and_compiled_give_the_element_wise_values(u: object, v: object) -> None:
    p = P(2.0, -3.0)
    py, jit = call(u, v, p), call.jit(u, v, p)
    if isinstance(u, tuple):
        vs = v if isinstance(v, tuple) else (v,) * len(u)
        expect = tuple(2.0 * a - 3.0 * math.sin(b) for a, b in zip(u, vs, strict=True))
        assert type(py) is tuple and type(jit) is tuple
    else:
        expect = 2.0 * u - 3.0 * math.sin(v)
    assert py == expect and jit == expect


def test_tuples_of_different_lengths_are_refused_in_both() -> None:
    p = P(1.0, 1.0)
    with pytest.raises(ValueError, match="different lengths"):
        call((1.0, 2.0), (1.0, 2.0, 3.0), p)
    with pytest.raises(Exception, match="different lengths"):
        call.jit((1.0, 2.0), (1.0, 2.0, 3.0), p)
