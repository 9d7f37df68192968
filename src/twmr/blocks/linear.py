"""Linear blocks: gain (scalar or matrix), sum (with signs), integrator, state space, unit
delay. Each is defined by its kernel (`twmr.blocks.kernels`, `twmr.blocks.routing_kernels`)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from twmr.blocks import discrete_kernels as dk
from twmr.blocks import kernels
from twmr.blocks import routing_kernels as rk
from twmr.blocks.routing import Nary
from twmr.core.component import Component
from twmr.core.ctwin import CTwin, checked, nary_sizes
from twmr.core.errors import CosimError
from twmr.core.kernel import Kernel
from twmr.core.port import INTEGER, STRING, Input, Output, Parameter

#: discretisations a state-space block keeps, one per step size [s]
DISCRETE_CACHE = 256


class Gain(Component):
    """y = k u (element-wise) or y = K u (a matrix).

    k scalar for n_in = n_out; K of n_out x n_in values given row by row; direct feedthrough."""

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
                     f"{self.n_in}.", "give K row by row, one row per output, one column per "
                     "input (or set n_in and n_out to its shape).")]
        if not self.K and self.n_in != self.n_out:
            return [("K", f"a scalar gain keeps the width, but n_in = {self.n_in} and n_out = "
                     f"{self.n_out}.", "give the matrix K, or equal n_in and n_out.")]
        return []

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        if not self.K:
            return Kernel(params=rk.GainParams(float(self.k)), evaluate=rk.gain_evaluate)
        m = self.n_in
        K = tuple(tuple(float(k) for k in self.K[i * m:(i + 1) * m]) for i in range(self.n_out))
        return Kernel(params=rk.GainMatrixParams(K), evaluate=rk.gain_matrix_evaluate)


class Sum(Nary):
    """y = s1 k1 u1 + s2 k2 u2 + s3 u3 + ..., n inputs with signs, element-wise.

    s_i is the sign (+ or -) of input
    i in `signs` (default '++': y = k1 u1 + k2 u2; k2 = -1 or signs '+-' make an error
    junction); direct feedthrough."""

    kind = "sum"
    OPS, ALPHABET = "signs", "+-"
    k1 = Parameter(1.0)
    k2 = Parameter(1.0)
    signs = Parameter("++", type=STRING, description="'+' or '-' per input, e.g. '+-+'")
    u1 = Input(0.0)
    u2 = Input(0.0)
    y = Output(0.0, depends_on=("u1", "u2"))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({}, {"signs": "+-+"}, {"signs": "-+", "n": 3}, {"signs": "++-+"})

    def kernel(self, h: float) -> Kernel:
        gains = [1.0 if c == "+" else -1.0 for c in self.signs]
        gains[0] *= self.k1
        gains[1] *= self.k2
        return Kernel(params=rk.NaryParams(tuple(gains)), evaluate=rk.sum_evaluate)


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
    """x' = A x + B u, y = C x + D u: n states, n_in inputs, n_out outputs.

    Discretised exactly for an input held over the step (zero-order hold) for each step size.

    A is n x n values row by row, B n x n_in, C n_out x n, D n_out x n_in (a scalar for a single
    input and output). y depends on u directly only when D != 0."""

    kind = "state_space"
    sized_by: ClassVar[dict[str, str]] = {"u": "n_in", "y": "n_out"}
    n_in = Parameter(1, type=INTEGER, min=1, description="elements of u")
    n_out = Parameter(1, type=INTEGER, min=1, description="elements of y")
    A = Parameter((0.0,), size=0, description="state matrix, row-major")
    B = Parameter((1.0,), size=0, description="input matrix, row-major")
    C = Parameter((1.0,), size=0, description="output matrix, row-major")
    D = Parameter(0.0, description="feedthrough (n_out x n_in, row-major, when not 1 x 1)")
    x0 = Parameter((), size=0, description="initial state (default zeros)")
    u = Input(0.0)
    y = Output(0.0)

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py); {}: drawn SISO."""
        return ({}, {}, {"n_in": 2, "n_out": 1, "A": [[-1.0, 2.0], [-3.0, -4.0]],
                         "B": [[1.0, 0.0], [0.5, 2.0]], "C": [1.0, -1.0], "D": [0.0, 0.0],
                         "x0": [0.5, -1.0]},
                {"n_in": 1, "n_out": 2, "A": [-2.0], "B": [1.5], "C": [1.0, 3.0],
                 "D": [0.5, 0.0], "x0": [0.2]})

    def set_parameter(self, name: str, value: Any) -> None:
        super().set_parameter(name, value)
        if name in ("n_in", "n_out"):  # D: a scalar for 1 x 1, else n_out x n_in
            size = self.n_in * self.n_out
            d = Parameter(0.0, description=self.variables["D"].description) if size == 1 else \
                Parameter((0.0,) * size, size=0, description=self.variables["D"].description)
            d.name = "D"
            self.variables["D"] = d
            self.__dict__["D"] = d.start
        if name in ("D", "n_in", "n_out"):  # feedthrough only when D != 0 (breaks loops)
            y = self.outputs["y"]
            direct = any(v != 0.0 for v in np.ravel(self.D))
            self.variables["y"] = Output(y.start, size=y.size, depends_on=("u",) if direct
                                         else ())
            self.variables["y"].name = "y"

    def order(self) -> int:
        """Number of states n (from B); ValueError naming a matrix of the wrong size."""
        m, p = self.n_in, self.n_out
        n = len(self.B) // m
        if n == 0 or n * m != len(self.B):
            raise ValueError(f"B has {len(self.B)} values, not n x n_in (n_in = {m}). Fix: give "
                             f"B as n rows of n_in values, at least one state.")
        sizes = {"A": n * n, "C": p * n, "D": p * m, "x0": n}
        for name, size in sizes.items():
            got = len(np.ravel(self.get(name)))
            if got != size and not (name == "x0" and got == 0):
                raise ValueError(f"{name} has {got} values but B has {n} states (expected "
                                 f"{size}). Fix: give A as n*n values row by row, B as n x n_in, "
                                 f"C as n_out x n, D as n_out x n_in and x0 as n values.")
        return n

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        try:
            self.order()
        except ValueError as err:
            message, fix = str(err).split(" Fix: ")
            return [("", message, fix)]
        return []

    def initialize(self) -> None:
        n, m, p = self.order(), self.n_in, self.n_out
        self._a = np.reshape(self.A, (n, n))
        self._b = np.reshape(self.B, (n, m))
        self._c = np.reshape(self.C, (p, n))
        self._d = np.reshape(np.array(self.D, dtype=float), (p, m))
        self._h = math.nan
        self._discrete: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        """The definition for steps of h [s] (the discretisation made here)."""
        if h != self._h:
            if h not in self._discrete:  # an adaptive master comes back to the same steps
                from scipy.signal import cont2discrete

                ad, bd, *_ = cont2discrete((self._a, self._b, self._c, self._d), h,
                                           method="zoh")
                if len(self._discrete) >= DISCRETE_CACHE:
                    self._discrete.clear()
                self._discrete[h] = ad, bd
            (self._ad, self._bd), self._h = self._discrete[h], h
        n = len(self._a)
        x = (np.array(self.x0 or [0.0] * n, dtype=float),)
        ad = np.ascontiguousarray(self._ad, dtype=float)
        if self.n_in == self.n_out == 1:
            return Kernel(params=kernels.StateSpaceParams(
                              ad, np.ascontiguousarray(self._bd[:, 0], dtype=float),
                              np.ascontiguousarray(self._c[0], dtype=float), float(self.D)),
                          state=x, evaluate=kernels.state_space_evaluate,
                          step=kernels.state_space_step)
        return Kernel(params=dk.StateSpaceMimoParams(
                          ad, np.ascontiguousarray(self._bd, dtype=float),
                          np.ascontiguousarray(self._c, dtype=float),
                          np.ascontiguousarray(self._d, dtype=float)),
                      state=x, evaluate=dk.state_space_mimo_evaluate,
                      step=dk.state_space_mimo_step)


# -- C twins (`twmr export KIND`: a standalone C FMU from c/<kind>.c) ------------------------------
C = Path(__file__).parent / "c"
#: the length of each matrix of a single-input single-output `state_space` block of n states (x0
#: may also be empty: zeros)
SS_LENGTHS = {"A": lambda n: n * n, "B": lambda n: n, "C": lambda n: n, "x0": lambda n: n}


def state_space_size(comp: Component) -> int:
    """Number of states n of a `state_space` block, its matrices checked (`StateSpace.order`)."""
    try:
        return int(comp.order())  # type: ignore[attr-defined]
    except ValueError as err:
        raise CosimError(f"export state_space: {err}") from None


def _ss_work(comp: Component) -> int:
    n = state_space_size(comp)
    return n * n + n * comp.get("n_in") + n + 1


def _ss_pinned(comp: Component) -> frozenset[str]:
    """D = 0 exports a block without feedthrough (y does not depend on u), so D stays 0."""
    return frozenset() if comp.has_feedthrough else frozenset({"D"})


def _gain(comp: Component) -> dict[str, int | str]:
    checked(comp)
    return {"GAIN_MATRIX": int(bool(comp.get("K"))), "N_IN": comp.get("n_in"),
            "N_OUT": comp.get("n_out")}


Gain.c_twin = CTwin(C / "gain.c", tunable=frozenset({"k", "K"}), sizes=_gain)
Sum.c_twin = CTwin(C / "sum.c", tunable=frozenset({"k1", "k2"}),
                   sizes=nary_sizes("SUM", "signs", "+-"))
Integrator.c_twin = CTwin(C / "integrator.c", tunable=frozenset({"k"}))
Delay.c_twin = CTwin(C / "delay.c")
StateSpace.c_twin = CTwin(
    C / "state_space.c", order=state_space_size, order_define="N_SS", lengths=SS_LENGTHS,
    orders=(1, 2, 3), work=_ss_work, pinned=_ss_pinned, headers=(C / "expm.h",),
    sizes=lambda comp: {"N_IN": comp.get("n_in"), "N_OUT": comp.get("n_out")})
