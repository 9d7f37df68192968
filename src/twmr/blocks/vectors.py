"""Vectors in kernels: a port of n > 1 elements is a tuple of n floats (`twmr.core.port`), a
scalar port a float; element-wise kernels read elements with `at` and build their outputs with
`put`, through `setitem` (a new tuple with one element replaced): plain tuple slicing in Python,
numba's tuple intrinsic in compiled code, the same values in both."""
from __future__ import annotations

import math
from typing import Any

from twmr.core.kernel import KernelFunction, kernel_function


class _TupleSetitem(KernelFunction):
    """`setitem(t, i, v)`: Python slices the tuple; compiled code calls numba's intrinsic."""

    @property
    def jit(self) -> Any:
        if self._jit is None:
            from numba import njit

            from twmr.blocks import _numba_tuple

            self._jit = njit(cache=True)(_numba_tuple.setitem)
        return self._jit


def _setitem(t: tuple, i: int, v: float) -> tuple:
    return (*t[:i], v, *t[i + 1:])


setitem = _TupleSetitem(_setitem)


@kernel_function
def at(v: float | tuple, i: int) -> float:
    """Element i of a port value (a scalar is its own element 0)."""
    if isinstance(v, float):
        return v
    return v[i]


@kernel_function
def put(v: float | tuple, i: int, e: float) -> float | tuple:
    """The port value `v` with element i set to e (a scalar becomes e)."""
    if isinstance(v, float):
        return e
    return setitem(v, i, e)


@kernel_function
def width(v: float | tuple) -> int:
    """Number of elements of a port value."""
    if isinstance(v, float):
        return 1
    return len(v)


@kernel_function
def divide(a: float, b: float) -> float:
    """a / b with IEEE's answers for b = 0 (+-inf, NaN for 0/0) in Python as in compiled code
    (Python raises ZeroDivisionError)."""
    if b != 0.0:
        return a / b
    if a == 0.0 or a != a:
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)
