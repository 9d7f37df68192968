"""Breakpoint tables shared by `table`, `lookup_1d` and `lookup_2d`: the interval search and the
linear interpolation (kernel functions), the extrapolation codes and the checks of a table's
shape and order (`twmr check`)."""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from twmr.core.kernel import kernel_function

#: extrapolation outside the breakpoints: hold the end value, extend the end segment, or NaN
EXTRAPOLATIONS = {"hold": 0.0, "linear": 1.0, "error": 2.0}
HOLD, LINEAR, ERROR = EXTRAPOLATIONS.values()
#: the interpolation of a time table between its points
INTERPOLATIONS = {"linear": 0.0, "hold": 1.0}
#: the extrapolation codes #defined for the C twins (c/tables.h)
EXTRAP_CODES = {f"EXTRAP_{k.upper()}": int(v) for k, v in EXTRAPOLATIONS.items()}

#: what `Component.check` returns: (parameter, what is wrong, how to fix it)
Problems = list[tuple[str, str, str]]


@kernel_function
def interval(bp: np.ndarray, u: float) -> int:
    """The index i in [0, n - 2] of the segment [bp[i], bp[i + 1]] that holds u (the first one
    below bp[0], the last one from bp[n - 1] on): the largest i with bp[i] <= u, by bisection."""
    lo, hi = 0, len(bp) - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if bp[mid] <= u:
            lo = mid
        else:
            hi = mid
    return lo


@kernel_function
def segment(bp: np.ndarray, u: float, extrapolation: float) -> tuple[int, float]:
    """(i, s): the segment i of u and its fraction s = (u - bp[i]) / (bp[i+1] - bp[i]), u held
    at the ends (HOLD), the end segments extended (LINEAR) or s = NaN outside (ERROR)."""
    first, last = bp[0], bp[len(bp) - 1]
    if extrapolation == HOLD:
        u = first if u < first else (last if u > last else u)
    elif extrapolation == ERROR and (u < first or u > last):
        return 0, math.nan
    i = interval(bp, u)
    return i, (u - bp[i]) / (bp[i + 1] - bp[i])


@kernel_function
def interp1(bp: np.ndarray, values: np.ndarray, u: float, extrapolation: float) -> float:
    """v_i + (v_{i+1} - v_i) s on the segment (i, s) of u (`segment`)."""
    i, s = segment(bp, u, extrapolation)
    return float(values[i] + (values[i + 1] - values[i]) * s)


@kernel_function
def interp2(bx: np.ndarray, by: np.ndarray, values: np.ndarray, u1: float, u2: float,
            extrapolation: float) -> float:
    """Bilinear interpolation in the grid values[i * len(by) + j] at (bx[i], by[j]): first
    along y in rows i and i + 1, then along x."""
    i, sx = segment(bx, u1, extrapolation)
    j, sy = segment(by, u2, extrapolation)
    m = len(by)
    a = values[i * m + j] + (values[i * m + j + 1] - values[i * m + j]) * sy
    b = values[(i + 1) * m + j] + (values[(i + 1) * m + j + 1] - values[(i + 1) * m + j]) * sy
    return float(a + (b - a) * sx)


def increasing(name: str, bp: Sequence[float], strict: bool = True) -> Problems:
    """The problem with breakpoints `bp` (parameter `name`): fewer than two, or not (strictly)
    increasing."""
    if len(bp) < 2:
        return [(name, f"{name} has {len(bp)} value(s); a table needs at least two.",
                 f"give two or more {name}, increasing.")]
    bad = next((i for i in range(1, len(bp)) if bp[i] < bp[i - 1] or
                (strict and bp[i] == bp[i - 1])), None)
    if bad is None:
        return []
    order = "strictly increasing" if strict else "non-decreasing"
    return [(name, f"{name} must be {order}, but {name}[{bad + 1}] = {bp[bad]:g} follows "
             f"{name}[{bad}] = {bp[bad - 1]:g}.",
             f"sort {name}, the values in the same order"
             f"{'; no breakpoint may repeat' if strict else ''}.")]


def same_length(name: str, values: Sequence[float], expected: int, shape: str) -> Problems:
    """The problem with table `name` when it does not hold `expected` values (`shape` says
    which)."""
    if len(values) == expected:
        return []
    return [(name, f"{name} has {len(values)} values but the breakpoints call for {expected} "
             f"({shape}).", f"give {name} as {shape}.")]


def choice(name: str, value: str, known: dict[str, float]) -> Problems:
    """The problem with a text parameter that is not one of `known`."""
    if value in known:
        return []
    return [(name, f"{name} '{value}' is not one of {', '.join(known)}.",
             f"set {name} to {' | '.join(known)}.")]


def array(values: Sequence[float]) -> np.ndarray:
    """A table as the kernel reads it: a contiguous float64 array."""
    return np.ascontiguousarray(values, dtype=float)
