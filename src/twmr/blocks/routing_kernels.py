"""The definitions of the signal-routing blocks (`twmr.blocks.routing`, and `gain` and `sum` of
`twmr.blocks.linear`): parameter tables and kernel functions (`twmr.core.kernel`). Ports of
n > 1 elements are tuples (`twmr.blocks.vectors`), scalar ports floats."""
from __future__ import annotations

import math
from typing import NamedTuple

from twmr.blocks.vectors import at, divide, put, width
from twmr.core.kernel import kernel_function

#: `math` functions by name -> code (shared with c/math.c through its #define)
FUNCTIONS = {"abs": 0, "sqrt": 1, "exp": 2, "log": 3, "log10": 4, "sin": 5, "cos": 6, "tan": 7,
             "asin": 8, "acos": 9, "atan": 10, "tanh": 11, "square": 12, "reciprocal": 13,
             "sign": 14}
#: exp(v) overflows to inf above this
EXP_MAX = math.log(1.7976931348623157e308)


class GainParams(NamedTuple):
    k: float


class GainMatrixParams(NamedTuple):
    K: tuple  #: n_out rows of n_in floats


class NaryParams(NamedTuple):
    """Per input i: its gain (`sum`: sign times k1, k2 or 1) or 1.0 to multiply by it, -1.0 to
    divide by it (`product`)."""

    gains: tuple  #: floats


class SelectParams(NamedTuple):
    picks: tuple  #: 0-based input element (int) of each output element


class MathParams(NamedTuple):
    fn: float  #: `FUNCTIONS` code


@kernel_function
def gain_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: GainParams) -> tuple[tuple, tuple]:
    """y = k u, element by element."""
    out = y[0]
    for i in range(width(out)):
        out = put(out, i, p.k * at(u[0], i))
    return x, (out,)


@kernel_function
def gain_matrix_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: GainMatrixParams
                         ) -> tuple[tuple, tuple]:
    """y_i = sum_j K_ij u_j (summed in order of j)."""
    out = y[0]
    for i in range(len(p.K)):
        row = p.K[i]
        s = row[0] * at(u[0], 0)
        for j in range(1, len(row)):
            s = s + row[j] * at(u[0], j)
        out = put(out, i, s)
    return x, (out,)


@kernel_function
def sum_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: NaryParams) -> tuple[tuple, tuple]:
    """y = g1 u1 + g2 u2 + ... (in order), element by element."""
    out = y[0]
    for i in range(width(out)):
        s = p.gains[0] * at(u[0], i)
        for j in range(1, len(u)):
            s = s + p.gains[j] * at(u[j], i)
        out = put(out, i, s)
    return x, (out,)


@kernel_function
def product_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: NaryParams
                     ) -> tuple[tuple, tuple]:
    """y = ((1 op1 u1) op2 u2) ..., op * (gain 1) or / (gain -1), element by element."""
    out = y[0]
    for i in range(width(out)):
        s = 1.0
        for j in range(len(u)):
            s = s * at(u[j], i) if p.gains[j] > 0.0 else divide(s, at(u[j], i))
        out = put(out, i, s)
    return x, (out,)


@kernel_function
def mux_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: tuple) -> tuple[tuple, tuple]:
    """y = (u1, u2, ...) concatenated."""
    out = y[0]
    w = width(u[0])
    for j in range(len(u)):
        for i in range(w):
            out = put(out, j * w + i, at(u[j], i))
    return x, (out,)


@kernel_function
def demux_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: tuple) -> tuple[tuple, tuple]:
    """(y1, y2, ...) = u cut into equal parts."""
    out = y
    w = width(y[0])
    for j in range(len(y)):
        part = y[j]
        for i in range(w):
            part = put(part, i, at(u[0], j * w + i))
        out = put(out, j, part)
    return x, out


@kernel_function
def selector_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: SelectParams
                      ) -> tuple[tuple, tuple]:
    """y_i = u[index_i]."""
    out = y[0]
    for i in range(len(p.picks)):
        out = put(out, i, at(u[0], p.picks[i]))
    return x, (out,)


@kernel_function
def apply(fn: float, v: float) -> float:
    """`FUNCTIONS` code fn of v; NaN outside the domain (as C's libm), inf where it overflows."""
    if fn == 0.0:
        return abs(v)
    if fn == 1.0:
        return math.sqrt(v) if v >= 0.0 else math.nan
    if fn == 2.0:
        return math.exp(v) if v <= EXP_MAX else math.inf
    if fn == 3.0 or fn == 4.0:
        if v > 0.0:
            return math.log(v) if fn == 3.0 else math.log10(v)
        return -math.inf if v == 0.0 else math.nan
    if fn >= 5.0 and fn <= 7.0:
        if v - v != 0.0:
            return math.nan
        if fn == 5.0:
            return math.sin(v)
        return math.cos(v) if fn == 6.0 else math.tan(v)
    if fn == 8.0 or fn == 9.0:
        if abs(v) <= 1.0:
            return math.asin(v) if fn == 8.0 else math.acos(v)
        return math.nan
    if fn == 10.0:
        return math.atan(v)
    if fn == 11.0:
        return math.tanh(v)
    if fn == 12.0:
        return v * v
    if fn == 13.0:
        return divide(1.0, v)
    if v > 0.0:
        return 1.0
    return -1.0 if v < 0.0 else v


@kernel_function
def math_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: MathParams) -> tuple[tuple, tuple]:
    """y = f(u), element by element."""
    out = y[0]
    for i in range(width(out)):
        out = put(out, i, apply(p.fn, at(u[0], i)))
    return x, (out,)
