"""Signal sources: outputs are functions of time only (no inputs, no feedthrough). Each is defined
by its kernel (`twmr.blocks.kernels`)."""
from __future__ import annotations

from pathlib import Path

from twmr.blocks import kernels
from twmr.core.component import Component
from twmr.core.ctwin import CTwin
from twmr.core.kernel import Kernel
from twmr.core.port import Output, Parameter


class Constant(Component):
    """y = value."""

    kind = "constant"
    value = Parameter(1.0, description="output value")
    y = Output(0.0)

    def initialize(self) -> None:
        self.y = self.value

    def kernel(self, h: float) -> Kernel:
        """Nothing to compute."""
        return Kernel()


class Sine(Component):
    """y(t) = offset + amplitude * sin(2 pi f t + phase)."""

    kind = "sine"
    amplitude = Parameter(1.0)
    frequency = Parameter(1.0, unit="Hz", min=0.0)
    phase = Parameter(0.0, unit="rad")
    offset = Parameter(0.0)
    y = Output(0.0)

    def _params(self) -> kernels.SineParams:
        return kernels.SineParams(float(self.amplitude), float(self.frequency),
                                  float(self.phase), float(self.offset))

    def initialize(self) -> None:
        self.y = kernels.sine_at(self.start_time, self._params())

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=self._params(), step=kernels.sine_step)


class Step(Component):
    """y(t) = offset for t < time, offset + height from then on."""

    kind = "step"
    height = Parameter(1.0)
    time = Parameter(0.0, unit="s")
    offset = Parameter(0.0)
    y = Output(0.0)

    def _params(self) -> kernels.StepParams:
        return kernels.StepParams(float(self.height), float(self.time), float(self.offset))

    def initialize(self) -> None:
        self.y = kernels.step_at(self.start_time, self._params())

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=self._params(), step=kernels.step_step)

    def next_event(self, t: float) -> float | None:
        return float(self.time) if t < self.time else None


# -- C twins (`twmr export KIND`: a standalone C FMU from c/<kind>.c) ------------------------------
C = Path(__file__).parent / "c"
Constant.c_twin = CTwin(C / "constant.c")
Sine.c_twin = CTwin(C / "sine.c", tunable=frozenset({"amplitude", "frequency", "phase", "offset"}))
Step.c_twin = CTwin(C / "step.c", tunable=frozenset({"height", "time", "offset"}))
