"""Incremental encoder of each wheel: counts of the true wheel angle, and a speed estimate from
them (docs/sensors.md).

    N = floor(phi cpr / (2 pi))                             (count; phi the true angle [rad])
    phi_q = N 2 pi / cpr                                    (quantised angle [rad])
    omega_hat(t_k) = (N(t_k) - N(t_{k-1})) 2 pi / (cpr (t_k - t_{k-1}))   (speed [rad/s])

The counts follow the angle at every communication point (direct feedthrough); the speed is a
finite difference of counts over the sample period: a sample is taken at the first communication
point at least `sample_period` after the previous one (the first at the first step, when the
estimate is 0), and the estimate is held until the next.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from twmr.components._sampled import sample_due
from twmr.components.ctwins import SAMPLED
from twmr.components.ctwins import C as TWINS
from twmr.core import Component, Input, Output, Parameter
from twmr.core.ctwin import CTwin
from twmr.core.kernel import Kernel, kernel_function


class EncoderParams(NamedTuple):
    """The encoder's parameter table."""

    cpr: float  #: counts per wheel revolution
    period: float  #: sample period of the speed estimate [s]; 0: every communication point


class EncoderState(NamedTuple):
    """The counts and time of the last speed sample."""

    count_R: float
    count_L: float
    t_last: float  #: [s]


@kernel_function
def encoder_count(angle: float, cpr: float) -> float:
    """N = floor(angle cpr / (2 pi)) of a true angle [rad]."""
    return np.floor(angle * cpr / (2.0 * math.pi))


@kernel_function
def encoder_evaluate(t: float, x: EncoderState, y: tuple, u: tuple, p: EncoderParams
                     ) -> tuple[EncoderState, tuple]:
    """u = (angle,); y = (count, measured_angle, speed): the counts at t, the speed estimate if
    a sample is due at t, else the one held."""
    nR, nL = encoder_count(u[0][0], p.cpr), encoder_count(u[0][1], p.cpr)
    speed = y[2]
    if sample_due(t, x.t_last, p.period):
        dt = t - x.t_last
        speed = ((nR - x.count_R) * (2.0 * math.pi) / (p.cpr * dt),
                 (nL - x.count_L) * (2.0 * math.pi) / (p.cpr * dt))
    return x, ((nR, nL), (nR * (2.0 * math.pi) / p.cpr, nL * (2.0 * math.pi) / p.cpr), speed)


@kernel_function
def encoder_step(t: float, h: float, x: EncoderState, y: tuple, u: tuple, p: EncoderParams
                 ) -> tuple[EncoderState, tuple]:
    """A sample due at t (or the first step's) keeps its counts and time for the next
    estimate."""
    if not (math.isnan(x.t_last) or sample_due(t, x.t_last, p.period)):
        return x, y
    x, y = encoder_evaluate(t, x, y, u, p)
    return EncoderState(y[0][0], y[0][1], t), y


class Encoder(Component):
    """Incremental encoders of the two wheels: counts, quantised angle, speed from counts."""

    kind = "encoder"
    cpr = Parameter(4096.0, min=1.0, description="counts per wheel revolution (after any "
                                                 "gear and quadrature decoding)")
    sample_period = Parameter(1e-3, unit="s", min=0.0,
                              description="period of the speed estimate; 0 = every step")

    angle = Input(size=2, unit="rad", description="true wheel angles (phi_R, phi_L)")
    count = Output(size=2, unit="1", depends_on=("angle",), description="counts N")
    measured_angle = Output(size=2, unit="rad", depends_on=("angle",),
                            description="quantised angle N 2 pi / cpr")
    speed = Output(size=2, unit="rad/s", depends_on=("angle",),
                   description="speed estimate from the counts, held over a sample period")

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.cpr != int(self.cpr):
            return [("cpr", f"cpr = {self.cpr} is not a whole number of counts.",
                     "give the counts per wheel revolution as a whole number, e.g. 4096.")]
        return []

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        """The encoder's definition (no sample yet: the first step takes it)."""
        return Kernel(params=EncoderParams(float(self.cpr), float(self.sample_period)),
                      state=EncoderState(0.0, 0.0, math.nan),
                      evaluate=encoder_evaluate, step=encoder_step)


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
Encoder.c_twin = CTwin(TWINS / "encoder.c", headers=(SAMPLED,),
                       tunable=frozenset({"sample_period"}), work=lambda comp: 3)
