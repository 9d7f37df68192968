"""`port_fault`: a fault on a wire, what a scenario's `events:` inserts between a port and the
ports it feeds (`twmr.scenario.events`). Between `start` and `stop` [s] the output is the input
made faulty, element-wise; before and after, the input as it is:

- `freeze`: the last input before `start`, held;
- `bias`: u + value; `scale`: u value;
- `noise`: u + value N(0, 1), one Philox-4x32-10 normal sequence per element (`seed`), a sample per
  step;
- `dropout`: 0 (the signal is lost); `stuck_at`: value;

on every element, or on element `element` alone (from 1).

Its ports take the unit of the faulted port (`unit`), so the wire converts as before.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar, NamedTuple

from twmr.blocks.philox import standard_normal
from twmr.core.component import Component
from twmr.core.elementwise import elementwise
from twmr.core.kernel import Kernel, kernel_function
from twmr.core.port import INTEGER, STRING, Input, Output, Parameter

#: the faults, by name, and their codes in the kernel
FAULTS = {"freeze": 0.0, "bias": 1.0, "scale": 2.0, "noise": 3.0, "dropout": 4.0,
          "stuck_at": 5.0}
#: times closer than this [s] are one instant (a fault starts at its step)
TOLERANCE = 1e-9


class FaultParams(NamedTuple):
    code: float  #: FAULTS
    start: float  #: [s]
    stop: float  #: [s] (inf: to the end)
    value: float
    seed: float
    element: float  #: the element faulted, from 1 (0: every one)


@elementwise
def faulty(u: float, held: float, i: float, k: float, p: FaultParams) -> float:
    """Element i of the faulty output: u, the held value, or the fault's value (u itself for
    an element the fault leaves alone)."""
    if p.element > 0.0 and i != p.element - 1.0:
        return u
    if p.code == 0.0:
        return held
    if p.code == 1.0:
        return u + p.value
    if p.code == 2.0:
        return u * p.value
    if p.code == 3.0:
        return u + p.value * standard_normal(int(p.seed), int(k), int(i))
    if p.code == 4.0:
        return 0.0
    return p.value


@kernel_function
def fault_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: FaultParams
                   ) -> tuple[tuple, tuple]:
    """x = (the input held for `freeze`, the element indices, the steps taken): y = u outside
    [start, stop), the faulty input inside."""
    tol = TOLERANCE * max(1.0, abs(t))
    if t < p.start - tol or t >= p.stop - tol:
        return (u[0], x[1], x[2]), (u[0],)
    return x, (faulty(u[0], x[0], x[1], x[2], p),)


@kernel_function
def fault_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: FaultParams
               ) -> tuple[tuple, tuple]:
    """Count the step (the noise's sample index)."""
    return (x[0], x[1], x[2] + 1.0), y


class PortFault(Component):
    """A fault on a wire between `start` and `stop` [s]: freeze, bias, scale, noise, dropout or
    stuck_at (`value`), element-wise."""

    kind = "port_fault"
    sized_by: ClassVar[dict[str, str]] = {"u": "n", "y": "n"}
    construction_parameters = ("unit",)
    n = Parameter(1, type=INTEGER, min=1, description="number of elements")
    fault = Parameter("freeze", type=STRING, description=" | ".join(FAULTS))
    start = Parameter(0.0, unit="s", description="when the fault begins")
    stop = Parameter(math.inf, unit="s", description="when it ends (inf: with the run)")
    value = Parameter(0.0, description="bias, factor, noise deviation or stuck value")
    seed = Parameter(0, type=INTEGER, min=0, max=2**32 - 1, description="noise: its seed")
    element = Parameter(0, type=INTEGER, min=0, description="the element faulted, from 1 "
                        "(0: every one)")
    unit = Parameter("", type=STRING, description="the unit of the faulted port")
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    def __init__(self, name: str = "", unit: str = "", **parameters: Any):
        """Its ports in `unit` (the faulted port's)."""
        super().__init__(name)
        self.set_parameter("unit", unit)
        for port in ("u", "y"):
            var = dataclasses.replace(self.variables[port], unit=unit)
            var.name = port
            self.variables[port] = var
        for key, value in parameters.items():
            self.set_parameter(key, value)

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({"fault": "freeze", "start": 2 * h}, {"fault": "bias", "value": 0.5, "n": 3},
                {"fault": "noise", "value": 0.1, "seed": 7, "n": 2, "stop": 5 * h},
                {"fault": "stuck_at", "value": -1.0, "n": 3, "element": 2})

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.fault not in FAULTS:
            return [("fault", f"fault '{self.fault}' is unknown.",
                     f"use one of: {', '.join(FAULTS)}.")]
        if self.element > self.variables["u"].width:
            return [("element", f"element {self.element} of a port of "
                     f"{self.variables['u'].width} element(s).",
                     f"give 1 to {self.variables['u'].width}, or 0 for every one.")]
        if not self.stop > self.start and math.isfinite(self.start):
            return [("stop", f"the fault ends ({self.stop:g} s) before it begins "
                     f"({self.start:g} s).", "give stop after start.")]
        return []

    def kernel(self, h: float) -> Kernel:
        n = self.variables["u"].width
        zeros: Any = 0.0 if n == 1 else (0.0,) * n
        index: Any = 0.0 if n == 1 else tuple(float(i) for i in range(n))
        return Kernel(params=FaultParams(FAULTS[self.fault], float(self.start), float(self.stop),
                                         float(self.value), float(self.seed),
                                         float(self.element)),
                      state=(zeros, index, 0.0), evaluate=fault_evaluate, step=fault_step)
