"""The definitions of the nonlinear blocks `saturation`, `dead_zone`, `rate_limiter`,
`quantizer`, `backlash`, `relay`, `lookup_1d` and `lookup_2d`: their parameter tables and kernel
functions (`twmr.core.kernel`), each written for one element and applied to every element of
the ports (`twmr.core.elementwise`). A comparison with NaN is false, so NaN inputs give NaN
outputs (the relay and the backlash keep their state)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twmr.blocks.tables import interp1, interp2
from twmr.core.elementwise import elementwise
from twmr.core.kernel import kernel_function


class LimitsParams(NamedTuple):
    lower: float
    upper: float


class RateParams(NamedTuple):
    rising: float  #: [unit of u / s] >= 0
    falling: float  #: [unit of u / s] >= 0


class QuantizerParams(NamedTuple):
    interval: float


class BacklashParams(NamedTuple):
    width: float  #: the dead band


class RelayParams(NamedTuple):
    on_point: float
    off_point: float
    on_value: float
    off_value: float


class Lookup1Params(NamedTuple):
    breakpoints: np.ndarray
    values: np.ndarray
    extrapolation: float  #: `tables.EXTRAPOLATIONS` code


class Lookup2Params(NamedTuple):
    x: np.ndarray
    y: np.ndarray
    values: np.ndarray  #: len(x) * len(y), row i at x[i]
    extrapolation: float


# -- memoryless -------------------------------------------------------------------------------
@elementwise
def saturate(u: float, p: LimitsParams) -> float:
    """lower below lower, upper above upper, u in between."""
    return p.lower if u < p.lower else (p.upper if u > p.upper else u)


@kernel_function
def saturation_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: LimitsParams
                        ) -> tuple[tuple, tuple]:
    return x, (saturate(u[0], p),)


@elementwise
def dead(u: float, p: LimitsParams) -> float:
    """0 in [lower, upper], u - upper above, u - lower below."""
    return u - p.lower if u < p.lower else (u - p.upper if u > p.upper else 0.0)


@kernel_function
def dead_zone_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: LimitsParams
                       ) -> tuple[tuple, tuple]:
    return x, (dead(u[0], p),)


@elementwise
def quantize(u: float, p: QuantizerParams) -> float:
    """interval * floor(u / interval + 1/2): the nearest level, halves rounded up."""
    return p.interval * float(np.floor(u / p.interval + 0.5))


@kernel_function
def quantizer_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: QuantizerParams
                       ) -> tuple[tuple, tuple]:
    return x, (quantize(u[0], p),)


@elementwise
def lookup1(u: float, p: Lookup1Params) -> float:
    return interp1(p.breakpoints, p.values, u, p.extrapolation)


@kernel_function
def lookup_1d_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: Lookup1Params
                       ) -> tuple[tuple, tuple]:
    return x, (lookup1(u[0], p),)


@elementwise
def lookup2(u1: float, u2: float, p: Lookup2Params) -> float:
    return interp2(p.x, p.y, p.values, u1, u2, p.extrapolation)


@kernel_function
def lookup_2d_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: Lookup2Params
                       ) -> tuple[tuple, tuple]:
    return x, (lookup2(u[0], u[1], p),)


# -- with memory ------------------------------------------------------------------------------
@elementwise
def rate_limit(u: float, y: float, h: float, p: RateParams) -> float:
    """y + (u - y) with the change held in [-falling h, rising h]."""
    d = u - y
    up, down = p.rising * h, -p.falling * h
    return y + (up if d > up else (down if d < down else d))


@kernel_function
def rate_limiter_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: RateParams
                      ) -> tuple[tuple, tuple]:
    """y(t + h) from y(t) and u(t)."""
    return x, (rate_limit(u[0], y[0], h, p),)


@elementwise
def engage(u: float, last: float, p: BacklashParams) -> float:
    """The output follows u - width/2 when u pushes it up, u + width/2 when u pulls it down,
    and keeps `last` while u moves within the dead band around it."""
    half = 0.5 * p.width
    if u - half > last:
        return u - half
    if u + half < last:
        return u + half
    return last


@kernel_function
def backlash_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: BacklashParams
                      ) -> tuple[tuple, tuple]:
    """y from u and the output kept at the last step, x = (last,)."""
    return x, (engage(u[0], x[0], p),)


@kernel_function
def backlash_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: BacklashParams
                  ) -> tuple[tuple, tuple]:
    """The output with u held becomes the one kept."""
    last = engage(u[0], x[0], p)
    return (last,), (last,)


@elementwise
def switch(u: float, on: float, p: RelayParams) -> float:
    """1 from u >= on_point, 0 from u <= off_point, else `on` kept (hysteresis)."""
    if u >= p.on_point:
        return 1.0
    if u <= p.off_point:
        return 0.0
    return on


@elementwise
def relay_output(on: float, p: RelayParams) -> float:
    return p.on_value if on == 1.0 else p.off_value


@kernel_function
def relay_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: RelayParams
                   ) -> tuple[tuple, tuple]:
    """y from the state switched by u, x = (state kept at the last step: 1 on, 0 off,)."""
    return x, (relay_output(switch(u[0], x[0], p), p),)


@kernel_function
def relay_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: RelayParams
               ) -> tuple[tuple, tuple]:
    on = switch(u[0], x[0], p)
    return (on,), (relay_output(on, p),)
