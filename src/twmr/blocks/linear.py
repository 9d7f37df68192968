"""Linear blocks: gain, sum, integrator, single-input single-output state space, unit delay. Each
is defined by its kernel (`twmr.blocks.kernels`)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from twmr.blocks import kernels
from twmr.core.component import Component
from twmr.core.kernel import Kernel
from twmr.core.port import Input, Output, Parameter


class Gain(Component):
    """y = k u (direct feedthrough)."""

    kind = "gain"
    k = Parameter(1.0)
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=kernels.GainParams(float(self.k)), evaluate=kernels.gain_evaluate)


class Sum(Component):
    """y = k1 u1 + k2 u2 (direct feedthrough); k2 = -1 makes an error junction."""

    kind = "sum"
    k1 = Parameter(1.0)
    k2 = Parameter(1.0)
    u1 = Input(0.0)
    u2 = Input(0.0)
    y = Output(0.0, depends_on=("u1", "u2"))

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=kernels.SumParams(float(self.k1), float(self.k2)),
                      evaluate=kernels.sum_evaluate)


class Integrator(Component):
    """x' = k u, y = x; exact for an input held over the step: x(t+h) = x(t) + k u h."""

    kind = "integrator"
    k = Parameter(1.0)
    x0 = Parameter(0.0, description="initial state")
    u = Input(0.0)
    y = Output(0.0)

    def initialize(self) -> None:
        self.y = self.x0

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=kernels.IntegratorParams(float(self.k)),
                      step=kernels.integrator_step)


class Delay(Component):
    """Unit delay of one step: y(t + h) = u(t). Breaks an algebraic loop."""

    kind = "delay"
    y0 = Parameter(0.0, description="output before the first step")
    u = Input(0.0)
    y = Output(0.0)

    def initialize(self) -> None:
        self.y = self.y0

    def kernel(self, h: float) -> Kernel:
        return Kernel(step=kernels.delay_step)


class StateSpace(Component):
    """x' = A x + B u, y = C x + D u (single input, single output, n states), discretised exactly
    for an input held over the step (zero-order hold) for each step size.

    A is n*n values row by row, B and C n values each. y depends on u directly only when D != 0."""

    kind = "state_space"
    A = Parameter((0.0,), size=0, description="state matrix, row-major")
    B = Parameter((1.0,), size=0, description="input column")
    C = Parameter((1.0,), size=0, description="output row")
    D = Parameter(0.0, description="feedthrough")
    x0 = Parameter((), size=0, description="initial state (default zeros)")
    u = Input(0.0)
    y = Output(0.0)

    def set_parameter(self, name: str, value: Any) -> None:
        super().set_parameter(name, value)
        if name == "D":  # feedthrough only when D != 0, so a strictly proper block breaks loops
            self.variables = dict(self.variables)
            self.variables["y"] = Output(0.0, depends_on=("u",) if self.D != 0.0 else ())
            self.variables["y"].name = "y"

    def initialize(self) -> None:
        n = len(self.B)
        self._a = np.reshape(self.A, (n, n))
        self._b = np.reshape(self.B, (n, 1))
        self._c = np.reshape(self.C, (1, n))
        self._h = math.nan
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        """The definition for steps of h [s] (the discretisation made here)."""
        if h != self._h:
            from scipy.signal import cont2discrete

            ad, bd, *_ = cont2discrete((self._a, self._b, self._c, [[self.D]]), h, method="zoh")
            self._ad, self._bd, self._h = ad, bd[:, 0], h
        n = len(self.B)
        return Kernel(params=kernels.StateSpaceParams(
                          np.ascontiguousarray(self._ad, dtype=float),
                          np.ascontiguousarray(self._bd, dtype=float),
                          np.ascontiguousarray(self._c[0], dtype=float), float(self.D)),
                      state=(np.array(self.x0 or [0.0] * n, dtype=float),),
                      evaluate=kernels.state_space_evaluate, step=kernels.state_space_step)
