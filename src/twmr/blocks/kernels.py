"""Compiled kernels of the engine's blocks (`twmr.master.compiled`): pure numba functions,
imported only when a run is compiled (numba stays unloaded otherwise)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def gain_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: tuple) -> tuple[tuple, tuple]:
    """y = k u; p = (k,)."""
    return x, (p[0] * u[0],)


@njit(cache=True)
def sum_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: tuple) -> tuple[tuple, tuple]:
    """y = k1 u1 + k2 u2; p = (k1, k2)."""
    return x, (p[0] * u[0] + p[1] * u[1],)


@njit(cache=True)
def integrator_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
                    ) -> tuple[tuple, tuple]:
    """y(t + h) = y + k u h; p = (k,)."""
    return x, (y[0] + p[0] * u[0] * h,)


@njit(cache=True)
def delay_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
               ) -> tuple[tuple, tuple]:
    """y(t + h) = u(t)."""
    return x, (u[0],)


@njit(cache=True)
def state_space_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: tuple
                         ) -> tuple[tuple, tuple]:
    """y = C x + D u; x = (state vector,), p = (A_d, b_d, c, D); the products through BLAS, as
    numpy's `@` in the Python block."""
    return x, (np.dot(p[2], x[0]) + p[3] * u[0],)


@njit(cache=True)
def state_space_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
                     ) -> tuple[tuple, tuple]:
    """x(t + h) = A_d x + b_d u (zero-order hold), then y = C x + D u."""
    new = np.dot(p[0], x[0]) + p[1] * u[0]
    return state_space_evaluate(t + h, (new,), y, u, p)


@njit(cache=True)
def sine_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
              ) -> tuple[tuple, tuple]:
    """y(t + h) = offset + amplitude sin(2 pi f (t + h) + phase); p = (amplitude, f, phase,
    offset)."""
    return x, (p[3] + p[0] * math.sin(2.0 * math.pi * p[1] * (t + h) + p[2]),)


@njit(cache=True)
def step_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
              ) -> tuple[tuple, tuple]:
    """y(t + h) = offset (+ height from `time` [s] on); p = (height, time, offset)."""
    return x, (p[2] + (p[0] if t + h >= p[1] else 0.0),)
