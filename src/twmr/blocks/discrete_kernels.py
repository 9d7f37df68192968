"""The definitions of the discrete and linear blocks (`twmr.blocks.discrete`): parameter tables
and kernel functions (`twmr.core.kernel`). A port of n > 1 elements is a tuple of n floats
(`twmr.blocks.vectors`), a scalar port a float: element-wise kernels handle both.
`transfer_function` runs the state-space kernels of `twmr.blocks.kernels`."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from twmr.blocks.vectors import at, put, width
from twmr.core.kernel import kernel_function

#: `pid` anti-windup codes (shared with c/pid.c through its #defines)
ANTIWINDUP = {"none": 0, "clamping": 1, "back_calculation": 2}


# -- first_order: y' = (K u - y) / T ------------------------------------------------------------
class FirstOrderParams(NamedTuple):
    """y(t + h) = a y + b u, the exact step for u held: a = exp(-h / T), b = K (1 - a)."""

    a: float
    b: float


@kernel_function
def first_order_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: FirstOrderParams
                     ) -> tuple[tuple, tuple]:
    """y(t + h) = a y + b u, element by element."""
    out = y[0]
    for i in range(width(out)):
        out = put(out, i, p.a * at(y[0], i) + p.b * at(u[0], i))
    return x, (out,)


# -- zero_order_hold -------------------------------------------------------------------------
class HoldParams(NamedTuple):
    m: float  #: steps per sample period (a whole number >= 1)


def hold_steps(period: float, h: float) -> float:
    """Steps of h [s] per sample period [s]: the nearest whole number, at least 1 (as
    c/zero_order_hold.c)."""
    return max(1.0, math.floor(period / h + 0.5)) if h > 0.0 else 1.0


@kernel_function
def hold_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: HoldParams) -> tuple[tuple, tuple]:
    """y = u at a sample instant (x = (steps since the last sample,) is 0), else held."""
    if x[0] == 0.0:
        return x, (u[0],)
    return x, y


@kernel_function
def hold_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: HoldParams
              ) -> tuple[tuple, tuple]:
    """One step later; the output holds until `hold_evaluate` samples at the next instant."""
    n = x[0] + 1.0
    return (0.0 if n >= p.m else n,), y


# -- transport_delay -------------------------------------------------------------------------
class DelayParams(NamedTuple):
    """y(t) = u(t - d h), d = k + frac (k >= 1 whole steps), interpolated linearly between the
    stored samples u(t - k h) and u(t - (k + 1) h)."""

    k: float
    frac: float


def delay_steps(delay: float, steps: int, h: float, buffer: int) -> tuple[float, float]:
    """(k, frac) of a delay of `steps` steps (when > 0) or of `delay` [s] for steps of h [s]: d =
    delay / h, rounded to a whole number within 1e-9 of one, at least 1 and at most
    buffer - 1 (c/transport_delay.c computes the same)."""
    if steps > 0:
        d = float(steps)
    else:
        d = delay / h if h > 0.0 else 1.0
        r = math.floor(d + 0.5)
        if abs(d - r) <= 1e-9 * r:
            d = r
    d = min(max(d, 1.0), buffer - 1.0)
    k = math.floor(d)
    return float(k), d - k


@kernel_function
def transport_delay_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: DelayParams
                         ) -> tuple[tuple, tuple]:
    """Store u(t) in the ring buffer x = (samples [buffer x n], index of the newest, number
    stored), then y(t + h) = (1 - frac) s[k - 1] + frac s[k], s[j] the sample j steps before
    the newest; y0 (the initial samples) while t + h - delay is before the first sample."""
    buf = x[0].copy()
    size = buf.shape[0]
    head = (x[1] + 1) % size
    stored = min(x[2] + 1, size)
    for i in range(buf.shape[1]):
        buf[head, i] = at(u[0], i)
    if p.k + p.frac > stored:
        return (buf, head, stored), y
    k = int(p.k)
    near, far = (head - k + 1) % size, (head - k) % size
    out = y[0]
    for i in range(buf.shape[1]):
        v = float(buf[near, i])
        if p.frac != 0.0:
            v = (1.0 - p.frac) * v + p.frac * buf[far, i]
        out = put(out, i, v)
    return (buf, head, stored), (out,)


# -- pid -------------------------------------------------------------------------------------
class PidParams(NamedTuple):
    """Parallel PID for steps of h: u = kp e + ki/s e + kd s/(1 + s/N) e, 1/s by forward Euler
    (h/(z - 1)) in the integral and in the derivative filter, so the direct feedthrough kp + kd N
    does not depend on h: D_k = (1 - N h) D_(k-1) + kd N (e_k - e_(k-1))."""

    kp: float
    ki_h: float  #: ki h
    kdn: float  #: kd N
    a: float  #: 1 - N h
    kb_h: float  #: kb h, the back-calculation gain times the step
    limit: float  #: 1.0 when the output is limited to [y_min, y_max]
    y_min: float
    y_max: float
    antiwindup: float  #: `ANTIWINDUP` code


@kernel_function
def pid_terms(x: tuple, e: float, p: PidParams) -> tuple[float, float, float]:
    """(derivative term D_k, unlimited output v, limited output y) for error e; x = (integral
    term I_k, D_(k-1), e_(k-1))."""
    d = p.a * x[1] + p.kdn * (e - x[2])
    v = p.kp * e + x[0] + d
    y = v
    if p.limit != 0.0:
        y = min(max(v, p.y_min), p.y_max)
    return d, v, y


@kernel_function
def pid_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: PidParams) -> tuple[tuple, tuple]:
    """y = sat(kp e + I + D) at t."""
    return x, (pid_terms(x, u[0], p)[2],)


@kernel_function
def pid_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: PidParams
             ) -> tuple[tuple, tuple]:
    """I_(k+1) = I_k + ki h e_k (clamping: not while the output is limited and ki e pushes it
    further; back-calculation: + kb h (y - v)); then the output for e held."""
    e = u[0]
    d, v, out = pid_terms(x, e, p)
    gain = p.ki_h * e
    if p.antiwindup == 1.0 and out != v and (v - out) * gain > 0.0:
        gain = 0.0
    elif p.antiwindup == 2.0:
        gain = gain + p.kb_h * (out - v)
    nx = (x[0] + gain, d, e)
    return nx, (pid_terms(nx, e, p)[2],)


# -- state_space with vector input and output ------------------------------------------------
class StateSpaceMimoParams(NamedTuple):
    """The zero-order-hold discretisation of x' = A x + B u for the step, and y = C x + D u."""

    a_d: np.ndarray  #: n x n
    b_d: np.ndarray  #: n x m
    c: np.ndarray  #: p x n
    d: np.ndarray  #: p x m


@kernel_function
def _vector(v: float | tuple, n: int) -> np.ndarray:
    out = np.empty(n)
    for i in range(n):
        out[i] = at(v, i)
    return out


@kernel_function
def state_space_mimo_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: StateSpaceMimoParams
                              ) -> tuple[tuple, tuple]:
    """y = C x + D u; x = (state vector,)."""
    r = np.dot(p.c, x[0]) + np.dot(p.d, _vector(u[0], p.d.shape[1]))
    out = y[0]
    for i in range(r.shape[0]):
        out = put(out, i, float(r[i]))
    return x, (out,)


@kernel_function
def state_space_mimo_step(t: float, h: float, x: tuple, y: tuple, u: tuple,
                          p: StateSpaceMimoParams) -> tuple[tuple, tuple]:
    """x(t + h) = A_d x + B_d u (zero-order hold), then y = C x + D u."""
    new = np.dot(p.a_d, x[0]) + np.dot(p.b_d, _vector(u[0], p.b_d.shape[1]))
    return state_space_mimo_evaluate(t + h, (new,), y, u, p)
