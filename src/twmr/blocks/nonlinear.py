"""Nonlinear blocks: saturation, dead zone, rate limiter, quantizer, backlash, relay with
hysteresis, 1-D and 2-D lookup tables. Each acts element by element on ports of n elements
(`n`, 1: scalars) and is defined by its kernel (`twmr.blocks.nonlinear_kernels`).

The ports are generic (unit '') unless `unit` names one: a generic wire connects to any unit
without conversion, so the output carries the input's unit, and limits, widths, points and
breakpoints are given in that unit. docs/blocks.md gives the equations."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, ClassVar

from twmr.blocks import nonlinear_kernels as nk
from twmr.blocks import tables
from twmr.blocks.tables import Problems
from twmr.core.component import Component
from twmr.core.ctwin import Choice, elements, elementwise, table_sizes
from twmr.core.kernel import Kernel
from twmr.core.port import INTEGER, STRING, Input, Output, Parameter
from twmr.core.units import parse_unit


class ElementBlock(Component):
    """A block of one input u and one output y of n elements each (n = 1: scalars). Its `unit`
    (default '': generic) is the unit of u and of the variables `united` with it, so a wire
    from another unit converts and parameters given as text ('-200 mN.m') convert to it."""

    sized_by: ClassVar[dict[str, str]] = {"u": "n", "y": "n"}
    sizing_parameters = frozenset({"unit"})  # set first: the parameters take their unit from it
    #: the variables in the unit of u
    united: ClassVar[tuple[str, ...]] = ("u", "y")
    n = Parameter(1, type=INTEGER, min=1, description="number of elements (1: a scalar)")
    unit = Parameter("", type=STRING, description="unit of u ('': any, no conversion)")
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    def set_parameter(self, name: str, value: Any) -> None:
        if name != "unit":
            super().set_parameter(name, value)
            return
        text = self.variables["unit"].coerce(value)
        if text:
            parse_unit(text)  # UnitError for text that is not a unit
        self.__dict__["unit"] = text
        self.variables = dict(self.variables)
        for key in self.united:
            var = dataclasses.replace(self.variables[key], unit=text)
            var.name = key
            self.variables[key] = var

    def each(self, value: float) -> float | tuple[float, ...]:
        """`value` for every element: a float (n = 1) or a tuple of n."""
        n = int(self.n)
        return float(value) if n == 1 else (float(value),) * n

    def initialize(self) -> None:
        self.evaluate(self.start_time)


def _ordered(low: str, lo: float, high: str, hi: float) -> Problems:
    if lo <= hi:
        return []
    return [(low, f"{low} = {lo:g} is above {high} = {hi:g}.",
             f"give {low} <= {high} (swap them?).")]


class Saturation(ElementBlock):
    """y = min(max(u, lower), upper) element by element."""

    kind = "saturation"
    united = ("u", "y", "lower", "upper")
    lower = Parameter(-1.0, description="lower limit [unit of u]")
    upper = Parameter(1.0, description="upper limit [unit of u]")

    def check(self, given: frozenset[str]) -> Problems:
        return _ordered("lower", self.lower, "upper", self.upper)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=nk.LimitsParams(float(self.lower), float(self.upper)),
                      evaluate=nk.saturation_evaluate)


class DeadZone(ElementBlock):
    """y = 0 for lower <= u <= upper, u - upper above, u - lower below."""

    kind = "dead_zone"
    united = ("u", "y", "lower", "upper")
    lower = Parameter(-0.5, description="start of the dead zone [unit of u]")
    upper = Parameter(0.5, description="end of the dead zone [unit of u]")

    def check(self, given: frozenset[str]) -> Problems:
        return _ordered("lower", self.lower, "upper", self.upper)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=nk.LimitsParams(float(self.lower), float(self.upper)),
                      evaluate=nk.dead_zone_evaluate)


class Quantizer(ElementBlock):
    """y = interval * floor(u / interval + 1/2), element by element.

    u rounded to the nearest multiple of `interval` (halves up)."""

    kind = "quantizer"
    united = ("u", "y", "interval")
    interval = Parameter(0.1, min=0.0, description="quantization step (> 0) [unit of u]")

    def check(self, given: frozenset[str]) -> Problems:
        if self.interval > 0.0:
            return []
        return [("interval", f"interval = {self.interval:g}; quantizing needs a step above 0.",
                 "give interval > 0 (in the unit of u).")]

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=nk.QuantizerParams(float(self.interval)),
                      evaluate=nk.quantizer_evaluate)


class RateLimiter(ElementBlock):
    """y(t + h) = y(t) + clip(u(t) - y(t), -falling h, rising h), element by element.

    y follows u at most at the given rates (no feedthrough: the change is made over the
    step)."""

    kind = "rate_limiter"
    united = ("u", "y", "y0")
    rising = Parameter(1.0, min=0.0, description="largest rate up [unit of u per second]")
    falling = Parameter(1.0, min=0.0, description="largest rate down [unit of u per second]")
    y0 = Parameter(0.0, description="output at the start (every element)")
    y = Output(0.0)

    def initialize(self) -> None:
        self.y = self.each(self.y0)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=nk.RateParams(float(self.rising), float(self.falling)),
                      step=nk.rate_limiter_step)


class Backlash(ElementBlock):
    """Backlash (play) of total width `width`, element by element.

    y stays while u moves within width/2 of it, else follows at u -+ width/2 (the output of a
    gear with slack driven by u)."""

    kind = "backlash"
    united = ("u", "y", "width", "y0")
    width = Parameter(1.0, min=0.0, description="dead band, total [unit of u]")
    y0 = Parameter(0.0, description="output at the start (every element)")

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=nk.BacklashParams(float(self.width)), state=(self.each(self.y0),),
                      evaluate=nk.backlash_evaluate, step=nk.backlash_step)


class Relay(ElementBlock):
    """Relay with hysteresis, element by element.

    Switches on (y = on_value) when u >= on_point, off (y = off_value) when u <= off_point, and
    keeps its state in between; off at the start."""

    kind = "relay"
    united = ("u", "on_point", "off_point")
    on_point = Parameter(0.5, description="switch-on threshold [unit of u]")
    off_point = Parameter(-0.5, description="switch-off threshold, <= on_point [unit of u]")
    on_value = Parameter(1.0, description="output when on")
    off_value = Parameter(0.0, description="output when off")

    def check(self, given: frozenset[str]) -> Problems:
        return _ordered("off_point", self.off_point, "on_point", self.on_point)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=nk.RelayParams(float(self.on_point), float(self.off_point),
                                            float(self.on_value), float(self.off_value)),
                      state=(self.each(0.0),), evaluate=nk.relay_evaluate, step=nk.relay_step)


def _strictly_increasing(params: dict[str, Any], *names: str) -> dict[str, Any]:
    """`params` with the breakpoints `names` sorted and spread to be strictly increasing."""
    out = dict(params)
    for name in names:
        bp = sorted(out[name])
        for i in range(1, len(bp)):
            bp[i] = max(bp[i], bp[i - 1] + 0.25)
        out[name] = tuple(bp)
    return out


class Lookup1D(ElementBlock):
    """y = piecewise-linear interpolation of a table at u, element by element.

    The table is (breakpoints[i], values[i]); outside the breakpoints y is held at the end
    values (hold), extended along the end segments (linear), or NaN (error: the run stops at
    the first NaN, naming the block)."""

    kind = "lookup_1d"
    united = ("u", "breakpoints")
    breakpoints = Parameter((-1.0, 0.0, 1.0), size=0,
                            description="strictly increasing [unit of u]")
    values = Parameter((1.0, 0.0, 1.0), size=0, description="the output at each breakpoint")
    extrapolation = Parameter("hold", type=STRING, description="hold | linear | error")

    @classmethod
    def example(cls, params: dict[str, Any], h: float) -> dict[str, Any]:
        """Drawn `params` made valid (tests draw them): the breakpoints strictly increasing."""
        return _strictly_increasing(params, "breakpoints")

    def check(self, given: frozenset[str]) -> Problems:
        return (tables.choice("extrapolation", self.extrapolation, tables.EXTRAPOLATIONS) or
                tables.increasing("breakpoints", self.breakpoints) or
                tables.same_length("values", self.values, len(self.breakpoints),
                                   "one per breakpoint"))

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=nk.Lookup1Params(tables.array(self.breakpoints),
                                              tables.array(self.values),
                                              tables.EXTRAPOLATIONS[self.extrapolation]),
                      evaluate=nk.lookup_1d_evaluate)


class Lookup2D(Component):
    """y = bilinear interpolation of a grid at (u1, u2), element by element.

    The grid is values[i][j] at (breakpoints1[i], breakpoints2[j]); outside it the inputs are
    held at the edges (hold), the edge cells extended (linear), or y is NaN (error)."""

    kind = "lookup_2d"
    sized_by: ClassVar[dict[str, str]] = {"u1": "n", "u2": "n", "y": "n"}
    n = Parameter(1, type=INTEGER, min=1, description="number of elements (1: a scalar)")
    breakpoints1 = Parameter((0.0, 1.0), size=0,
                             description="breakpoints of u1, strictly increasing")
    breakpoints2 = Parameter((0.0, 1.0, 2.0), size=0,
                             description="breakpoints of u2, strictly increasing")
    values = Parameter(((0.0, 1.0, 4.0), (1.0, 2.0, 3.0)), size=0,
                       description="a row of len(breakpoints2) values for each "
                       "of breakpoints1")
    extrapolation = Parameter("hold", type=STRING, description="hold | linear | error")
    u1 = Input(0.0)
    u2 = Input(0.0)
    y = Output(0.0, depends_on=("u1", "u2"))

    @classmethod
    def example(cls, params: dict[str, Any], h: float) -> dict[str, Any]:
        """Drawn `params` made valid (tests draw them): both breakpoint sets increasing."""
        return _strictly_increasing(params, "breakpoints1", "breakpoints2")

    def check(self, given: frozenset[str]) -> Problems:
        rows, cols = len(self.breakpoints1), len(self.breakpoints2)
        return (tables.choice("extrapolation", self.extrapolation, tables.EXTRAPOLATIONS) or
                tables.increasing("breakpoints1", self.breakpoints1) or
                tables.increasing("breakpoints2", self.breakpoints2) or
                tables.same_length("values", self.values, rows * cols,
                                   f"{rows} rows (one per breakpoints1) of {cols} values "
                                   f"(one per breakpoints2)"))

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=nk.Lookup2Params(tables.array(self.breakpoints1),
                                              tables.array(self.breakpoints2),
                                              tables.array(self.values),
                                              tables.EXTRAPOLATIONS[self.extrapolation]),
                      evaluate=nk.lookup_2d_evaluate)


# -- C twins (`twmr export KIND`: a standalone C FMU from c/<kind>.c) ------------------------------
C = Path(__file__).parent / "c"
_EXTRAP = {"extrapolation": Choice("EXTRAP", {k: int(v) for k, v in
                                              tables.EXTRAPOLATIONS.items()})}

Saturation.c_twin = elementwise(C / "saturation.c", tunable=frozenset({"lower", "upper"}))
DeadZone.c_twin = elementwise(C / "dead_zone.c", tunable=frozenset({"lower", "upper"}))
Quantizer.c_twin = elementwise(C / "quantizer.c", tunable=frozenset({"interval"}))
RateLimiter.c_twin = elementwise(C / "rate_limiter.c", tunable=frozenset({"rising", "falling"}))
Backlash.c_twin = elementwise(C / "backlash.c", tunable=frozenset({"width"}), work=elements)
Relay.c_twin = elementwise(C / "relay.c", tunable=frozenset({"on_point", "off_point", "on_value",
                                                            "off_value"}), work=elements)
Lookup1D.c_twin = elementwise(C / "lookup_1d.c", headers=(C / "tables.h",),
                              defines=tables.EXTRAP_CODES, choices=_EXTRAP,
                              sizes=table_sizes(N_BP="breakpoints"))
Lookup2D.c_twin = elementwise(C / "lookup_2d.c", headers=(C / "tables.h",),
                              defines=tables.EXTRAP_CODES, choices=_EXTRAP,
                              sizes=table_sizes(N_BP1="breakpoints1", N_BP2="breakpoints2"))
