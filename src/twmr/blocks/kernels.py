"""The definitions of the engine's blocks: their parameter tables and kernel functions
(`twmr.core.kernel`; gain and sum are in `twmr.blocks.routing_kernels`). Plain Python in a
Python run (numba stays unloaded); compiled by numba when the compiled loop calls them."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from twmr.core.kernel import kernel_function


class IntegratorParams(NamedTuple):
    k: float


class SineParams(NamedTuple):
    amplitude: float
    frequency: float  #: [Hz]
    phase: float  #: [rad]
    offset: float


class StepParams(NamedTuple):
    height: float
    time: float  #: [s]
    offset: float


class StateSpaceParams(NamedTuple):
    """The zero-order-hold discretisation of x' = A x + B u for the step, and y = C x + D u."""

    a_d: np.ndarray  #: n x n
    b_d: np.ndarray  #: n
    c: np.ndarray  #: n
    d: float


@kernel_function
def integrator_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: IntegratorParams
                    ) -> tuple[tuple, tuple]:
    """y(t + h) = y + k u h."""
    return x, (y[0] + p.k * u[0] * h,)


@kernel_function
def delay_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
               ) -> tuple[tuple, tuple]:
    """y(t + h) = u(t)."""
    return x, (u[0],)


@kernel_function
def state_space_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: StateSpaceParams
                         ) -> tuple[tuple, tuple]:
    """y = C x + D u; x = (state vector,). The product through BLAS (`np.dot`), in Python as in
    numba."""
    return x, (np.dot(p.c, x[0]) + p.d * u[0],)


@kernel_function
def state_space_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: StateSpaceParams
                     ) -> tuple[tuple, tuple]:
    """x(t + h) = A_d x + b_d u (zero-order hold), then y = C x + D u."""
    new = np.dot(p.a_d, x[0]) + p.b_d * u[0]
    return state_space_evaluate(t + h, (new,), y, u, p)


@kernel_function
def sine_at(t: float, p: SineParams) -> float:
    """offset + amplitude sin(2 pi f t + phase) at t [s]."""
    return p.offset + p.amplitude * math.sin(2.0 * math.pi * p.frequency * t + p.phase)


@kernel_function
def sine_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: SineParams
              ) -> tuple[tuple, tuple]:
    """y(t + h)."""
    return x, (sine_at(t + h, p),)


@kernel_function
def step_at(t: float, p: StepParams) -> float:
    """offset, plus height from `time` [s] on, at t [s]."""
    return p.offset + (p.height if t >= p.time else 0.0)


@kernel_function
def step_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: StepParams
              ) -> tuple[tuple, tuple]:
    """y(t + h)."""
    return x, (step_at(t + h, p),)
