"""The definitions of the `data` block: its parameter table and kernel functions
(`twmr.core.kernel`). The samples are one table: `times` [s] non-decreasing, `values` row by row
(row k holds the n elements at times[k])."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from twmr.blocks.tables import ERROR, HOLD, interval
from twmr.core.elementwise import elementwise
from twmr.core.kernel import kernel_function

#: a time this fraction of a segment's length before a sample time is that time
SNAP = 1e-9


class DataParams(NamedTuple):
    times: np.ndarray  #: [s] non-decreasing, at least two
    values: np.ndarray  #: m rows of n elements, row by row
    n: float  #: elements per row
    hold: float  #: 1: zero-order hold between samples, 0: linear
    extrapolation: float  #: `tables.EXTRAPOLATIONS` code outside [times[0], times[-1]]
    time_offset: float  #: [s] sample time 0 plays at run time time_offset
    scale: float  #: y = scale * sample
    elements: float | tuple  #: the element numbers 0..n-1 (a tuple for n > 1)


@kernel_function
def data_sample(t: float, i: int, p: DataParams) -> float:
    """Element i at run time t: the samples at u = t - time_offset, held or linear between
    them; outside them the end sample held (hold), the end segment extended (linear, for linear
    interpolation) or NaN (error). A u within SNAP of a segment's length of a sample time is that
    time (t + h lands a rounding off the time n h a sample was recorded at)."""
    n = int(p.n)
    times, values = p.times, p.values
    last = len(times) - 1
    u = t - p.time_offset
    below = SNAP * (times[1] - times[0])
    above = SNAP * (times[last] - times[last - 1])
    if u < times[0] - below or u > times[last] + above:
        if p.extrapolation == ERROR:
            return math.nan
        if p.extrapolation == HOLD or p.hold == 1.0:
            return p.scale * values[(0 if u < times[0] else last) * n + i]
    elif u >= times[last] - above:
        return p.scale * values[last * n + i]
    elif u < times[0]:
        u = times[0]
    k = interval(times, u)
    if times[k + 1] - u <= SNAP * (times[k + 1] - times[k]):
        u = times[k + 1]
        k = interval(times, u)
    elif u - times[k] <= SNAP * (times[k + 1] - times[k]):
        u = times[k]
    if p.hold == 1.0:
        return p.scale * values[k * n + i]
    a = values[k * n + i]
    s = (u - times[k]) / (times[k + 1] - times[k])
    return p.scale * (a + (values[(k + 1) * n + i] - a) * s)


@elementwise
def data_element(t: float, i: float, p: DataParams) -> float:
    return data_sample(t, int(i), p)


@kernel_function
def data_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: DataParams
              ) -> tuple[tuple, tuple]:
    """y(t + h)."""
    return x, (data_element(t + h, p.elements, p),)
