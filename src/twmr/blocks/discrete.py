"""Discrete and linear blocks: transfer function, PID, transport delay, zero-order hold, first
order lag. Each is defined by its kernel (`twmr.blocks.discrete_kernels`); set-up decisions (a
discretisation, a number of steps) are made in `kernel(h)`, once per step size."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from twmr.blocks import discrete_kernels as dk
from twmr.blocks import kernels
from twmr.core.component import Component
from twmr.core.ctwin import Choice, CTwin, checked
from twmr.core.errors import ComponentError
from twmr.core.kernel import Kernel
from twmr.core.port import BOOLEAN, INTEGER, STRING, Input, Output, Parameter
from twmr.core.run import RunContext

#: how a `transfer_function` is discretised (or that its coefficients are already in z)
TF_METHODS = {"zoh": 0, "tustin": 1, "discrete": 2}
#: relative tolerance of "a whole number of steps"
WHOLE = 1e-9


def whole_steps(period: float, h: float) -> float | None:
    """period / h when it is a whole number >= 1 within `WHOLE`, else None."""
    d = period / h
    r = math.floor(d + 0.5)
    return float(r) if r >= 1 and abs(d - r) <= WHOLE * r else None


def _strip(c: tuple[float, ...]) -> tuple[float, ...]:
    """Coefficients without their leading zeros."""
    i = 0
    while i < len(c) - 1 and c[i] == 0.0:
        i += 1
    return c[i:]


def realise(num: tuple[float, ...], den: tuple[float, ...]
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(A, B, C, D) of num(s)/den(s) in controllable canonical form (den[0] != 0, degree of num
    at most that of den): with den = s^n + a1 s^(n-1) + ... + an and num = b0 s^n + ... + bn
    after dividing by den[0], A = [[-a1 ... -an], [I 0]], B = e1, C_i = b_i - a_i b0, D = b0.
    In z the same matrices are the discrete realisation (c/transfer_function.c builds them the
    same way)."""
    n = len(den) - 1
    a = [c / den[0] for c in den]
    b = [0.0] * (n + 1 - len(num)) + [c / den[0] for c in num][max(0, len(num) - n - 1):]
    A = np.zeros((n, n))
    A[0, :] = [-v for v in a[1:]]
    A[1:, :-1] += np.eye(n - 1)
    B = np.zeros(n)
    B[0] = 1.0
    C = np.array([b[i] - a[i] * b[0] for i in range(1, n + 1)])
    return A, B, C, b[0]


class _Feedthrough(Component):
    """A block whose output `y` depends on `u` directly only for some parameters
    (`feedthrough()`), re-declared when they change so a block without it breaks loops; the
    base step, from `prepare(run)`, stands for h before the first step (`step_of`), so its
    first output is the one the compiled loop computes."""

    _step = 0.0  #: [s] the base step; 0 without `prepare` (h = 0 is a valid limit here)

    def prepare(self, run: RunContext) -> None:
        self._step = run.step

    def step_of(self, h: float) -> float:
        """h, or the base step for h = 0 (the kernel made before the first step) [s]."""
        return h if h > 0.0 else self._step

    def feedthrough(self) -> bool:
        raise NotImplementedError

    def set_parameter(self, name: str, value: Any) -> None:
        super().set_parameter(name, value)
        if self.variables[name].kind == "parameter":
            y = self.outputs["y"]
            deps = ("u",) if self.feedthrough() else ()
            if y.depends_on != deps:
                self.variables = dict(self.variables)
                self.variables["y"] = Output(y.start, size=y.size, unit=y.unit,
                                             depends_on=deps, description=y.description)
                self.variables["y"].name = "y"


class TransferFunction(_Feedthrough):
    """y = num/den u, a transfer function in s (discretised) or in z.

    Coefficients in descending powers, discretised for the step h by `method`: 'zoh' (exact
    for u held over the step, the default), 'tustin' (bilinear s = 2/h (z - 1)/(z + 1)), or
    'discrete' (num and den are already in z at the block's step).
    Proper: degree of num <= degree of den >= 1. y depends on u directly when D != 0 (a
    biproper transfer function, or any under tustin)."""

    kind = "transfer_function"
    num = Parameter((1.0,), size=0, description="numerator coefficients, highest power first")
    den = Parameter((1.0, 1.0), size=0,
                    description="denominator coefficients, highest power first")
    method = Parameter("zoh", type=STRING, description="zoh | tustin | discrete")
    u = Input(0.0)
    y = Output(0.0)

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({"num": [1.0], "den": [0.05, 1.0]},
                {"num": [2.0, 1.0], "den": [1.0, 0.8, 4.0]},
                {"num": [0.5, 0.0, 1.0], "den": [1.0, 2.0, 3.0]},
                {"num": [1.0, -0.5], "den": [1.0, -1.2, 0.5]},
                {"num": [0.0, 0.1, 0.2, 0.3], "den": [1.0, 0.4, 0.3, 0.2]})

    def set_parameter(self, name: str, value: Any) -> None:
        """num is kept without leading zeros (so its length tells whether D can be != 0)."""
        if name == "num":
            value = _strip(self.variables["num"].coerce(value))
        super().set_parameter(name, value)

    def feedthrough(self) -> bool:
        return self.method == "tustin" or len(self.num) == len(self.den)

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        num, den = self.num, self.den
        if self.method not in TF_METHODS:
            return [("method", f"method '{self.method}' is not known.",
                     f"use one of {' | '.join(TF_METHODS)}.")]
        if len(den) < 2:
            return [("den", f"den {list(den)} has degree 0 (a static gain).",
                     "give den at least two coefficients (degree >= 1), or use a gain block.")]
        if den[0] == 0.0:
            return [("den", f"den {list(den)} has a leading zero (its degree is unclear).",
                     "drop the leading zeros of den, highest power first.")]
        if not num:
            return [("num", "num is empty.", "give at least one coefficient.")]
        if len(num) > len(den):
            return [("num", f"num {list(num)} has a higher degree ({len(num) - 1}) than "
                     f"den ({len(den) - 1}): the transfer function is improper.",
                     "make the degree of num at most that of den.")]
        return []

    def initialize(self) -> None:
        self._h = math.nan
        a, b, c, d = realise(self.num, self.den)
        self._abcd = (a, b, c, d)
        if self.feedthrough():
            self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        """The definition for steps of h [s] (the discretisation made here)."""
        a, b, c, d = self._abcd
        h = self.step_of(h)
        if h != self._h:
            if self.method == "discrete":
                self._disc = (a, b, c, d)
            else:
                from scipy.signal import cont2discrete

                method = "zoh" if self.method == "zoh" else "bilinear"
                ad, bd, cd, dd, _ = cont2discrete((a, b[:, None], c[None, :], [[d]]), h,
                                                  method=method)
                self._disc = (ad, bd[:, 0], cd[0], float(np.asarray(dd)[0, 0]))
            self._h = h
        ad, bd, cd, dd = self._disc
        return Kernel(params=kernels.StateSpaceParams(
                          np.ascontiguousarray(ad, dtype=float),
                          np.ascontiguousarray(bd, dtype=float),
                          np.ascontiguousarray(cd, dtype=float), float(dd)),
                      state=(np.zeros(len(b)),),
                      evaluate=kernels.state_space_evaluate, step=kernels.state_space_step)


class FirstOrder(Component):
    """First-order lag K/(T s + 1), element-wise.

    T y' + y = K u, exact for u held over the step: y(t + h) = a y + K (1 - a) u, a = exp(-h/T);
    no direct feedthrough."""

    kind = "first_order"
    sized_by: ClassVar[dict[str, str]] = {"u": "n", "y": "n"}
    n = Parameter(1, type=INTEGER, min=1, description="number of elements")
    K = Parameter(1.0, description="static gain")
    T = Parameter(1.0, unit="s", min=0.0, description="time constant (> 0)")
    y0 = Parameter(0.0, description="initial output")
    u = Input(0.0)
    y = Output(0.0)

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.T <= 0.0:
            return [("T", f"T = {self.T} s is not a positive time constant.",
                     "give T > 0 (a pure gain is a gain block).")]
        return []

    def initialize(self) -> None:
        self.y = self.variables["y"].coerce(self.y0)

    def kernel(self, h: float) -> Kernel:
        a = math.exp(-h / self.T) if self.T > 0.0 else 0.0
        return Kernel(params=dk.FirstOrderParams(a, self.K * (1.0 - a)),
                      step=dk.first_order_step)


class ZeroOrderHold(Component):
    """Zero-order hold at a sample period Ts, element-wise.

    y = u(t_k) for t_k <= t < t_k + Ts, sampled at t_k = start + k Ts (Ts a whole number of the
    block's steps); y depends on u directly (at the sample instants)."""

    kind = "zero_order_hold"
    sized_by: ClassVar[dict[str, str]] = {"u": "n", "y": "n"}
    n = Parameter(1, type=INTEGER, min=1, description="number of elements")
    sample_period = Parameter(0.01, unit="s", min=0.0, description="Ts (> 0)")
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({"sample_period": h}, {"sample_period": 3 * h}, {"n": 3, "sample_period": 4 * h})

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.sample_period <= 0.0:
            return [("sample_period", f"sample_period = {self.sample_period} s is not positive.",
                     "give a sample period of at least one step.")]
        return []

    def check_step(self, h: float) -> list[tuple[str, str, str]]:
        if whole_steps(self.sample_period, h) is None:
            return [("sample_period", f"sample_period = {self.sample_period} s is not a whole "
                     f"number of steps of {h} s.", "give a multiple of the step.")]
        return []

    def prepare(self, run: RunContext) -> None:
        _refuse(self, self.check_step(run.step))

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=dk.HoldParams(dk.hold_steps(self.sample_period, h)), state=(0.0,),
                      evaluate=dk.hold_evaluate, step=dk.hold_step)


class TransportDelay(Component):
    """Transport delay y(t) = u(t - delay) of a time or of N steps, element-wise.

    Linear interpolation between the samples stored at the steps (exact
    for a whole number of steps; `steps` > 0 gives a delay of that many steps instead); at least
    one step, so no direct feedthrough; y = y0 while t - delay < start. Element-wise for n > 1;
    `buffer` samples are stored (delay <= (buffer - 1) steps)."""

    kind = "transport_delay"
    sized_by: ClassVar[dict[str, str]] = {"u": "n", "y": "n"}
    n = Parameter(1, type=INTEGER, min=1, description="number of elements")
    delay = Parameter(0.0, unit="s", min=0.0, description="time delay (steps = 0)")
    steps = Parameter(0, type=INTEGER, min=0, description="delay in steps (> 0: used)")
    buffer = Parameter(1024, type=INTEGER, min=2, description="samples stored")
    y0 = Parameter(0.0, description="output until the delay has passed")
    u = Input(0.0)
    y = Output(0.0)

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({"steps": 3, "buffer": 8}, {"delay": 2.5 * h, "buffer": 8},
                {"n": 2, "delay": 4.0 * h, "buffer": 6}, {"delay": 0.3 * h, "buffer": 4})

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if "delay" in given and "steps" in given and self.steps > 0:
            return [("steps", "both delay and steps are given.",
                     "give the delay either in seconds (delay) or in steps (steps).")]
        if self.steps > self.buffer - 1:
            return [("steps", f"steps = {self.steps} does not fit a buffer of {self.buffer} "
                     f"samples.", f"give buffer >= {self.steps + 1}.")]
        return []

    def check_step(self, h: float) -> list[tuple[str, str, str]]:
        d = self.steps if self.steps > 0 else self.delay / h
        if d > self.buffer - 1 + WHOLE * d:
            return [("delay", f"delay = {self.delay} s is {d:g} steps of {h} s, more than a "
                     f"buffer of {self.buffer} samples holds.",
                     f"give buffer >= {math.ceil(d) + 1}.")]
        return []

    def prepare(self, run: RunContext) -> None:
        _refuse(self, self.check_step(run.step))

    def initialize(self) -> None:
        self.y = self.variables["y"].coerce(self.y0)

    def kernel(self, h: float) -> Kernel:
        k, frac = dk.delay_steps(self.delay, self.steps, h, self.buffer)
        buf = np.full((self.buffer, self.n), float(self.y0))
        return Kernel(params=dk.DelayParams(k, frac), state=(buf, 0, 0),
                      step=dk.transport_delay_step)


class Pid(_Feedthrough):
    """Discrete parallel PID with derivative filter, output limits and anti-windup.

    y = kp e + ki/s e + kd s/(1 + s/N) e of the error e = u at the block's step h
    (1/s by forward Euler in the integral and the derivative filter, starting from rest; the
    filter is stable for N h < 2), the
    output limited to [y_min, y_max] when limit_output; anti-windup 'clamping' (the integral
    stops while the output is limited and the error drives it further) or 'back_calculation'
    (the integral is fed kb (y - v), v the unlimited output). y depends on u directly unless
    kp = kd = 0."""

    kind = "pid"
    kp = Parameter(1.0, description="proportional gain")
    ki = Parameter(0.0, unit="1/s", description="integral gain")
    kd = Parameter(0.0, unit="s", description="derivative gain")
    N = Parameter(100.0, unit="1/s", min=0.0, description="derivative filter coefficient")
    kb = Parameter(1.0, unit="1/s", min=0.0, description="back-calculation gain")
    limit_output = Parameter(False, type=BOOLEAN, description="limit y to [y_min, y_max]")
    y_min = Parameter(-1.0, description="lower output limit")
    y_max = Parameter(1.0, description="upper output limit")
    antiwindup = Parameter("none", type=STRING, description="none | clamping | back_calculation")
    u = Input(0.0, description="error e")
    y = Output(0.0, depends_on=("u",))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py): N h < 2."""
        return ({"N": 0.5 / h}, {"N": 1.5 / h, "kd": 0.2 * h}, {"kd": 0.0, "N": 1.0},
                {"N": 0.1 / h, "kp": 0.0, "kd": 0.0})

    def feedthrough(self) -> bool:
        return self.kp != 0.0 or self.kd != 0.0

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.antiwindup not in dk.ANTIWINDUP:
            return [("antiwindup", f"antiwindup '{self.antiwindup}' is not known.",
                     f"use one of {' | '.join(dk.ANTIWINDUP)}.")]
        if self.limit_output and self.y_min > self.y_max:
            return [("y_min", f"the lower limit y_min = {self.y_min} is above the upper limit "
                     f"y_max = {self.y_max}.", "give y_min <= y_max.")]
        return []

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def check_step(self, h: float) -> list[tuple[str, str, str]]:
        if self.kd != 0.0 and self.N * h >= 2.0:
            return [("N", f"N = {self.N} 1/s makes the derivative filter unstable at steps of "
                     f"{h} s (its pole 1 - N h = {1.0 - self.N * h:g} is outside the unit "
                     f"circle).", f"give N < {2.0 / h:g} 1/s, or a smaller step.")]
        return []

    def prepare(self, run: RunContext) -> None:
        super().prepare(run)
        _refuse(self, self.check_step(run.step))

    def kernel(self, h: float) -> Kernel:
        h = self.step_of(h)
        return Kernel(params=dk.PidParams(
                          float(self.kp), self.ki * h, self.kd * self.N, 1.0 - self.N * h,
                          self.kb * h, float(self.limit_output), float(self.y_min),
                          float(self.y_max), float(dk.ANTIWINDUP.get(self.antiwindup, 0))),
                      state=(0.0, 0.0, 0.0), evaluate=dk.pid_evaluate, step=dk.pid_step)


def _refuse(comp: Component, problems: list[tuple[str, str, str]]) -> None:
    """A run not built from a scenario (the test Harness) refuses what `check_step` found."""
    if problems:
        _, message, fix = problems[0]
        raise ComponentError(comp.name, None, f"parameter {message} Fix: {fix}")


# -- C twins (`twmr export KIND`: a standalone C FMU from c/<kind>.c) ------------------------------
C = Path(__file__).parent / "c"


def _tf_order(comp: Component) -> int:
    return len(checked(comp).get("den")) - 1


def _tf_work(comp: Component) -> int:
    n = _tf_order(comp)
    return 2 * n * n + 4 * n + 2


def _pid_pinned(comp: Component) -> frozenset[str]:
    """kp = kd = 0 exports a block without feedthrough, so they stay 0."""
    return frozenset() if comp.has_feedthrough else frozenset({"kp", "kd"})


TransferFunction.c_twin = CTwin(
    C / "transfer_function.c", headers=(C / "expm.h",), order=_tf_order, order_define="TF_N",
    choices={"method": Choice("TF_METHOD", {m: TF_METHODS[m] for m in ("zoh", "discrete")})},
    sizes=lambda comp: {"NUM_LEN": len(comp.get("num"))}, work=_tf_work)
Pid.c_twin = CTwin(C / "pid.c", tunable=frozenset({"kp", "ki", "kd", "N", "kb", "y_min", "y_max"}),
                   choices={"antiwindup": Choice("PID_AW", dk.ANTIWINDUP),
                            "limit_output": Choice("PID_LIMIT", {False: 0, True: 1})},
                   work=lambda comp: 4, pinned=_pid_pinned)
TransportDelay.c_twin = CTwin(
    C / "transport_delay.c",
    sizes=lambda comp: {"TD_N": comp.get("n"), "TD_B": comp.get("buffer"),
                        "TD_STEPS": comp.get("steps")},
    work=lambda comp: comp.get("buffer") * comp.get("n") + 2)
ZeroOrderHold.c_twin = CTwin(C / "zero_order_hold.c", tunable=frozenset({"sample_period"}),
                             sizes=lambda comp: {"N_EL": comp.get("n")})
FirstOrder.c_twin = CTwin(C / "first_order.c", tunable=frozenset({"K", "T"}),
                          sizes=lambda comp: {"N_EL": comp.get("n")})
