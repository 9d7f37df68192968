"""Signal sources: outputs are functions of time only (no inputs, no feedthrough)."""
from __future__ import annotations

import math

from twmr.core.component import Component
from twmr.core.port import Output, Parameter
from twmr.master.compiled import Kernel


class Constant(Component):
    """y = value."""

    kind = "constant"
    value = Parameter(1.0, description="output value")
    y = Output(0.0)

    def initialize(self) -> None:
        self.y = self.value

    def kernel(self, h: float) -> Kernel:
        """The compiled form: nothing to compute."""
        return Kernel()


class Sine(Component):
    """y(t) = offset + amplitude * sin(2 pi f t + phase)."""

    kind = "sine"
    amplitude = Parameter(1.0)
    frequency = Parameter(1.0, unit="Hz", min=0.0)
    phase = Parameter(0.0, unit="rad")
    offset = Parameter(0.0)
    y = Output(0.0)

    def _at(self, t: float) -> float:
        return self.offset + self.amplitude * math.sin(2.0 * math.pi * self.frequency * t
                                                       + self.phase)

    def initialize(self) -> None:
        self.y = self._at(self.start_time)

    def kernel(self, h: float) -> Kernel:
        """The compiled form."""
        from twmr.blocks import kernels

        return Kernel(params=(float(self.amplitude), float(self.frequency), float(self.phase),
                              float(self.offset)), step=kernels.sine_step)

    def do_step(self, t: float, h: float) -> None:
        self.y = self._at(t + h)


class Step(Component):
    """y(t) = offset for t < time, offset + height from then on."""

    kind = "step"
    height = Parameter(1.0)
    time = Parameter(0.0, unit="s")
    offset = Parameter(0.0)
    y = Output(0.0)

    def _at(self, t: float) -> float:
        return self.offset + (self.height if t >= self.time else 0.0)

    def initialize(self) -> None:
        self.y = self._at(self.start_time)

    def do_step(self, t: float, h: float) -> None:
        self.y = self._at(t + h)

    def kernel(self, h: float) -> Kernel:
        """The compiled form."""
        from twmr.blocks import kernels

        return Kernel(params=(float(self.height), float(self.time), float(self.offset)),
                      step=kernels.step_step)
