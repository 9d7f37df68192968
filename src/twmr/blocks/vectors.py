"""Vectors in kernels: a port of n > 1 elements is a tuple of n floats (`twmr.core.port`), which
kernels build element by element with `setitem` (a new tuple with one element replaced): plain
tuple slicing in Python, numba's tuple intrinsic in compiled code, the same values in both."""
from __future__ import annotations

from typing import Any

from twmr.core.kernel import KernelFunction


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
