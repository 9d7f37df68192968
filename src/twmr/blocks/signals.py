"""More signal sources: ramp, pulse train, time table, seeded noise, linear chirp. Outputs are
functions of time only (no inputs); each is defined by its kernel (`twmr.blocks.signal_kernels`).
Their outputs are generic (unit ''): the parameters that set levels are in the unit of whatever
the output drives. docs/blocks.md gives the equations."""
from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

from twmr.blocks import signal_kernels as sk
from twmr.blocks import tables
from twmr.blocks.tables import Problems
from twmr.core.component import Component
from twmr.core.ctwin import Choice, CTwin, elementwise, table_sizes
from twmr.core.errors import ComponentError
from twmr.core.kernel import Kernel
from twmr.core.port import INTEGER, STRING, Output, Parameter
from twmr.core.run import RunContext


class Ramp(Component):
    """y(t) = offset + slope * max(0, t - time)."""

    kind = "ramp"
    slope = Parameter(1.0, description="rate of rise [unit of y per second]")
    time = Parameter(0.0, unit="s", description="start of the ramp")
    offset = Parameter(0.0, description="output before the start")
    y = Output(0.0)

    def _params(self) -> sk.RampParams:
        return sk.RampParams(float(self.slope), float(self.time), float(self.offset))

    def initialize(self) -> None:
        self.y = sk.ramp_at(self.start_time, self._params())

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=self._params(), step=sk.ramp_step)


class Pulse(Component):
    """Pulse train: y = offset + amplitude for `width` s of every `period` s from `delay` on.

    Offset otherwise (before `delay` too)."""

    kind = "pulse"
    amplitude = Parameter(1.0)
    period = Parameter(1.0, unit="s", min=0.0, description="time between rising edges (> 0)")
    width = Parameter(0.5, unit="s", min=0.0, description="time high in each period")
    delay = Parameter(0.0, unit="s", description="first rising edge")
    offset = Parameter(0.0)
    y = Output(0.0)

    def check(self, given: frozenset[str]) -> Problems:
        if not self.period > 0.0:
            return [("period", f"period = {self.period:g} s; a pulse train needs a period "
                     f"above 0.", "give period > 0 s.")]
        if self.width > self.period:
            return [("width", f"width = {self.width:g} s is longer than the period "
                     f"({self.period:g} s).", "give 0 <= width <= period (width = period: "
                     "always high).")]
        return []

    def _params(self) -> sk.PulseParams:
        return sk.PulseParams(float(self.amplitude), float(self.period), float(self.width),
                              float(self.delay), float(self.offset))

    def initialize(self) -> None:
        self.y = sk.pulse_at(self.start_time, self._params())

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=self._params(), step=sk.pulse_step)


class Table(Component):
    """y(t) from time-value pairs, linear or held between them.

    Linear between points, or held from each point (hold); the first value before the first
    time, the last from the last time on."""

    kind = "table"
    times = Parameter((0.0, 1.0, 2.0), size=0, unit="s",
                      description="sample times, non-decreasing (a repeated time: a jump)")
    values = Parameter((0.0, 1.0, 0.0), size=0, description="the value at each time")
    interpolation = Parameter("linear", type=STRING, description="linear | hold")
    y = Output(0.0)

    @classmethod
    def example(cls, params: dict[str, Any], h: float) -> dict[str, Any]:
        """Drawn `params` made valid (tests draw them): the times sorted."""
        return {**params, "times": tuple(sorted(params.get("times", cls.times.start)))}

    def check(self, given: frozenset[str]) -> Problems:
        return (tables.choice("interpolation", self.interpolation, tables.INTERPOLATIONS) or
                tables.increasing("times", self.times, strict=False) or
                tables.same_length("values", self.values, len(self.times), "one per time"))

    def _params(self) -> sk.TableParams:
        return sk.TableParams(tables.array(self.times), tables.array(self.values),
                              tables.INTERPOLATIONS[self.interpolation])

    def initialize(self) -> None:
        self.y = sk.table_at(self.start_time, self._params())

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=self._params(), step=sk.table_step)


class Noise(Component):
    """Seeded Gaussian or uniform noise, a sample every `period` s held, n elements.

    Mean `mean`, standard deviation `stddev`; held between samples (band-limited: about
    1 / (2 period) Hz); n independent elements. Sample k of element i is Philox-4x32 of (k, i)
    under `seed`, so the same seed gives the same sequence in Python, compiled and C, whatever
    the step."""

    kind = "noise"
    sized_by: ClassVar[dict[str, str]] = {"y": "n"}
    n = Parameter(1, type=INTEGER, min=1, description="number of elements (1: a scalar)")
    distribution = Parameter("gaussian", type=STRING, description="gaussian | uniform")
    mean = Parameter(0.0)
    stddev = Parameter(1.0, min=0.0, description="standard deviation (uniform: half-width / "
                       "sqrt(3))")
    seed = Parameter(0, type=INTEGER, min=0, max=2**53, description="seed of the generator")
    period = Parameter(0.0, unit="s", min=0.0, description="sample period (0: every step); "
                       "a multiple of the step")
    y = Output(0.0)

    @classmethod
    def example(cls, params: dict[str, Any], h: float) -> dict[str, Any]:
        """Drawn `params` made valid for steps of h [s] (tests draw them): a period of 0 to 4
        steps."""
        return {**params, "period": round(4.0 * params.get("period", 0.0)) * h}

    def check(self, given: frozenset[str]) -> Problems:
        return tables.choice("distribution", self.distribution,
                             {k: v for k, v in sk.DISTRIBUTIONS.items()})

    def check_step(self, h: float) -> Problems:
        steps = self.period / h
        if self.period == 0.0 or abs(steps - round(steps)) <= 1e-9 * max(1.0, steps):
            return []
        return [("period", f"period = {self.period:g} s is not a multiple of the step {h:g} s "
                 f"({steps:.6g} steps), so samples would not fall on communication points.",
                 "give period as k * step (or 0: a sample every step).")]

    def prepare(self, run: RunContext) -> None:
        """Refuses a period off the step (a run not built from a scenario: `Harness`)."""
        super().prepare(run)
        for _, message, fix in self.check_step(run.step):
            raise ComponentError(self.name, None, f"noise: {message} Fix: {fix}")

    def _params(self) -> sk.NoiseParams:
        n = int(self.n)
        elements = 0.0 if n == 1 else tuple(float(i) for i in range(n))
        return sk.NoiseParams(float(self.mean), float(self.stddev),
                              sk.DISTRIBUTIONS[self.distribution], float(self.seed),
                              float(self.period), float(self.start_time), elements)

    def initialize(self) -> None:
        p = self._params()
        self.y = sk.noise_element(0, p.elements, p)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=self._params(), step=sk.noise_step)


class Chirp(Component):
    """Linear sine sweep (chirp) from f0 to f1 over `duration`, starting at `time`.

    y = offset + amplitude sin(2 pi (f0 tau + (f1 - f0) tau^2 / (2 duration)) + phase),
    tau = max(0, t - time); the frequency keeps rising at the same rate after `duration`."""

    kind = "chirp"
    amplitude = Parameter(1.0)
    f0 = Parameter(0.1, unit="Hz", min=0.0, description="frequency at the start")
    f1 = Parameter(10.0, unit="Hz", min=0.0, description="frequency after `duration`")
    duration = Parameter(10.0, unit="s", min=0.0, description="sweep time (> 0)")
    time = Parameter(0.0, unit="s", description="start of the sweep")
    phase = Parameter(0.0, unit="rad")
    offset = Parameter(0.0)
    y = Output(0.0)

    def check(self, given: frozenset[str]) -> Problems:
        if self.duration > 0.0:
            return []
        return [("duration", f"duration = {self.duration:g} s; the sweep needs a duration "
                 f"above 0.", "give duration > 0 s.")]

    def _params(self) -> sk.ChirpParams:
        return sk.ChirpParams(float(self.amplitude), float(self.f0), float(self.f1),
                              float(self.duration), float(self.time), float(self.phase),
                              float(self.offset))

    def initialize(self) -> None:
        self.y = sk.chirp_at(self.start_time, self._params())

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=self._params(), step=sk.chirp_step)


# -- C twins (`twmr export KIND`: a standalone C FMU from c/<kind>.c) ------------------------------
C = Path(__file__).parent / "c"
TABLES_H = C / "tables.h"
_DISTRIBUTIONS = {k: int(v) for k, v in sk.DISTRIBUTIONS.items()}

Ramp.c_twin = CTwin(C / "ramp.c", tunable=frozenset({"slope", "time", "offset"}))
Pulse.c_twin = CTwin(C / "pulse.c", tunable=frozenset({"amplitude", "width", "delay", "offset"}))
Chirp.c_twin = CTwin(C / "chirp.c", tunable=frozenset({"amplitude", "offset"}))
Table.c_twin = CTwin(C / "table.c", headers=(TABLES_H,), defines=tables.EXTRAP_CODES,
                     choices={"interpolation": Choice("INTERP_HOLD", {
                         k: int(v) for k, v in tables.INTERPOLATIONS.items()})},
                     sizes=table_sizes(N_TABLE="times"))
Noise.c_twin = elementwise(C / "noise.c", headers=(C / "philox.h",),
                           tunable=frozenset({"mean", "stddev"}),
                           defines={f"DIST_{k.upper()}": v for k, v in _DISTRIBUTIONS.items()},
                           choices={"distribution": Choice("DIST", _DISTRIBUTIONS)},
                           sizes=lambda comp: {"SEED": int(comp.get("seed"))})
