"""The definitions of the signal sources `ramp`, `pulse`, `table`, `noise` and `chirp`: their
parameter tables and kernel functions (`twmr.core.kernel`); `noise` draws from the one
counter-based generator, `twmr.blocks.philox`."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from twmr.blocks.philox import box_muller, draw
from twmr.blocks.tables import interp1, interval
from twmr.core.elementwise import elementwise
from twmr.core.kernel import kernel_function

#: noise distributions (codes shared with c/noise.c through config.h)
DISTRIBUTIONS = {"gaussian": 0.0, "uniform": 1.0}
SQRT3 = 1.7320508075688772
#: sample counts are floor((t - t0) / Ts + SLACK): a time a rounding below k Ts is sample k
SLACK = 1e-6


class RampParams(NamedTuple):
    slope: float  #: [unit of y / s]
    time: float  #: [s] when the ramp starts
    offset: float


class PulseParams(NamedTuple):
    amplitude: float
    period: float  #: [s]
    width: float  #: [s] time high in each period
    delay: float  #: [s] start of the first pulse
    offset: float


class TableParams(NamedTuple):
    times: np.ndarray  #: [s] non-decreasing
    values: np.ndarray
    hold: float  #: 1: zero-order hold between points, 0: linear


class NoiseParams(NamedTuple):
    mean: float
    stddev: float
    uniform: float  #: DISTRIBUTIONS code
    seed: float  #: whole number in [0, 2^64)
    period: float  #: [s] sample period, 0: every step
    t0: float  #: [s] time of sample 0 (the start time)
    elements: float | tuple  #: the element numbers 0..n-1 (a tuple for n > 1)


class ChirpParams(NamedTuple):
    amplitude: float
    f0: float  #: [Hz] at the start
    f1: float  #: [Hz] after `duration`
    duration: float  #: [s]
    time: float  #: [s] when the sweep starts
    phase: float  #: [rad]
    offset: float


# -- ramp, pulse, chirp, table: functions of time ---------------------------------------------
@kernel_function
def ramp_at(t: float, p: RampParams) -> float:
    """y = offset + slope max(0, t - time)."""
    return p.offset + (p.slope * (t - p.time) if t > p.time else 0.0)


@kernel_function
def ramp_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: RampParams
              ) -> tuple[tuple, tuple]:
    return x, (ramp_at(t + h, p),)


@kernel_function
def pulse_at(t: float, p: PulseParams) -> float:
    """y = offset + amplitude while fmod(t - delay, period) < width (t >= delay), else offset
    (fmod exact, as C's)."""
    if t < p.delay:
        return p.offset
    return p.offset + (p.amplitude if np.fmod(t - p.delay, p.period) < p.width else 0.0)


@kernel_function
def pulse_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: PulseParams
               ) -> tuple[tuple, tuple]:
    return x, (pulse_at(t + h, p),)


@kernel_function
def chirp_at(t: float, p: ChirpParams) -> float:
    """y = offset + amplitude sin(2 pi (f0 tau + (f1 - f0) tau^2 / (2 duration)) + phase),
    tau = max(0, t - time): instantaneous frequency f0 + (f1 - f0) tau / duration [Hz]."""
    tau = t - p.time if t > p.time else 0.0
    cycles = p.f0 * tau + (p.f1 - p.f0) * tau * tau / (2.0 * p.duration)
    return p.offset + p.amplitude * math.sin(2.0 * math.pi * cycles + p.phase)


@kernel_function
def chirp_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: ChirpParams
               ) -> tuple[tuple, tuple]:
    return x, (chirp_at(t + h, p),)


@kernel_function
def table_at(t: float, p: TableParams) -> float:
    """values[0] before times[0], values[-1] from times[-1] on; between, the point before t
    (hold) or the line through the points around it (linear)."""
    n = len(p.times)
    if t < p.times[0]:
        return float(p.values[0])
    if t >= p.times[n - 1]:
        return float(p.values[n - 1])
    if p.hold == 1.0:
        return float(p.values[interval(p.times, t)])
    return interp1(p.times, p.values, t, 0.0)


@kernel_function
def table_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: TableParams
               ) -> tuple[tuple, tuple]:
    return x, (table_at(t + h, p),)


# -- noise ------------------------------------------------------------------------------------
@kernel_function
def noise_sample(k: int, i: int, p: NoiseParams) -> float:
    """Sample k of element i: draw (k, i) of `seed` (`twmr.blocks.philox`); uniform:
    mean + stddev sqrt(3) (2 r - 1); Gaussian: mean + stddev n (Box-Muller)."""
    r1, r2 = draw(int(p.seed), k, i)
    if p.uniform == 1.0:
        return p.mean + p.stddev * SQRT3 * (2.0 * r1 - 1.0)
    return p.mean + p.stddev * box_muller(r1, r2)


@kernel_function
def noise_count(t: float, h: float, p: NoiseParams) -> int:
    """The sample number at t [s]: floor((t - t0) / Ts + SLACK), Ts = period (h when 0)."""
    period = p.period if p.period > 0.0 else h
    return math.floor((t - p.t0) / period + SLACK)


@elementwise
def noise_element(k: int, i: float, p: NoiseParams) -> float:
    return noise_sample(k, int(i), p)


@kernel_function
def noise_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: NoiseParams
               ) -> tuple[tuple, tuple]:
    """y(t + h): the sample held over [k Ts, (k + 1) Ts)."""
    return x, (noise_element(noise_count(t + h, h, p), p.elements, p),)
