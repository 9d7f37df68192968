"""Linear blocks: gain (scalar or matrix), sum (with signs), integrator, state space, unit
delay. Each is defined by its kernel (`twmr.blocks.kernels`, `twmr.blocks.routing_kernels`)."""
from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from twmr.blocks import kernels
from twmr.blocks import routing_kernels as rk
from twmr.blocks.routing import Nary
from twmr.core.component import Component
from twmr.core.kernel import Kernel
from twmr.core.port import INTEGER, STRING, Input, Output, Parameter


class Gain(Component):
    """y = k u element by element (n_in = n_out), or y = K u for a matrix K of n_out x n_in
    values given row by row; direct feedthrough."""

    kind = "gain"
    sized_by: ClassVar[dict[str, str]] = {"u": "n_in", "y": "n_out"}
    n_in = Parameter(1, type=INTEGER, min=1, description="elements of u")
    n_out = Parameter(1, type=INTEGER, min=1, description="elements of y")
    k = Parameter(1.0, description="scalar gain (when K is empty)")
    K = Parameter((), size=0, description="gain matrix, n_out x n_in row by row")
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({}, {"n_in": 3, "n_out": 3},
                {"n_in": 3, "n_out": 2, "K": [[1.0, -2.0, 0.5], [0.25, 3.0, -1.0]]},
                {"n_in": 2, "n_out": 1, "K": [2.0, -1.5]})

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.K and len(self.K) != self.n_out * self.n_in:
            return [("K", f"K has {len(self.K)} values, not n_out x n_in = {self.n_out} x "
                     f"{self.n_in}", "give K row by row, one row per output, one column per "
                     "input (or set n_in and n_out to its shape).")]
        if not self.K and self.n_in != self.n_out:
            return [("K", f"a scalar gain keeps the width, but n_in = {self.n_in} and n_out = "
                     f"{self.n_out}", "give the matrix K, or equal n_in and n_out.")]
        return []

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        if not self.K:
            return Kernel(params=rk.GainParams(float(self.k)), evaluate=rk.gain_evaluate)
        K = np.reshape(np.array(self.K, dtype=float), (self.n_out, self.n_in))
        return Kernel(params=rk.GainMatrixParams(K), evaluate=rk.gain_matrix_evaluate)


class Sum(Nary):
    """y = s1 k1 u1 + s2 k2 u2 + s3 u3 + ... element by element, s_i the sign (+ or -) of input
    i in `signs` (default '++': y = k1 u1 + k2 u2; k2 = -1 or signs '+-' make an error
    junction); direct feedthrough."""

    kind = "sum"
    OPS, ALPHABET = "signs", "+-"
    k1 = Parameter(1.0)
    k2 = Parameter(1.0)
    signs = Parameter("++", type=STRING, description="'+' or '-' per input, e.g. '+-+'")
    y = Output(0.0, depends_on=("u1", "u2"))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({}, {"signs": "+-+"}, {"signs": "-+", "n": 3}, {"signs": "++-+"})

    def kernel(self, h: float) -> Kernel:
        gains = [1.0 if c == "+" else -1.0 for c in self.signs]
        gains[0] *= self.k1
        gains[1] *= self.k2
        return Kernel(params=rk.NaryParams(np.array(gains)), evaluate=rk.sum_evaluate)


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
