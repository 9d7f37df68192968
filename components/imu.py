"""Yaw-rate gyro of an IMU with a constant bias and seeded Gaussian noise (docs/sensors.md).

The robot's model gives the heading theta, not its rate, so the gyro is a rate-integrating one
(the delta-angle output of an IMU): at each sample k it reports the heading change since the
previous sample over the time between them, which is the true mean yaw rate over that interval,

    r_k = (theta(t_k) - theta(t_{k-1})) / (t_k - t_{k-1}) + bias + noise_std n_k

with n_k sample k of the standard normal sequence of `seed` (`twmr.blocks.philox`, the one
generator of the blocks, the same in Python, compiled and C). Sample 0 is at the start time
with no rate (r_0 = bias + noise_std n_0; its heading is taken at the first step); a sample is
taken at the first communication point at least `sample_period` after the previous one, and held
until the next.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from twmr.blocks.philox import standard_normal
from twmr.components._sampled import sample_due
from twmr.components.ctwins import PHILOX, SAMPLED
from twmr.components.ctwins import C as TWINS
from twmr.core import Component, Input, Output, Parameter
from twmr.core.ctwin import CTwin
from twmr.core.kernel import Kernel, kernel_function

#: largest seed: seeds are whole numbers an FMU's Real parameter holds exactly
SEED_MAX = 2.0 ** 53 - 1.0


class ImuParams(NamedTuple):
    """The gyro's parameter table."""

    bias: float  #: [rad/s]
    noise_std: float  #: standard deviation of each sample's noise [rad/s]
    seed: float  #: whole number in [0, SEED_MAX]
    period: float  #: sample period [s]; 0: every communication point


class ImuState(NamedTuple):
    """The heading, time and index of the last sample."""

    heading: float  #: [rad]
    t_last: float  #: [s]
    k: float  #: sample index


@kernel_function
def imu_evaluate(t: float, x: ImuState, y: tuple, u: tuple, p: ImuParams
                 ) -> tuple[ImuState, tuple]:
    """u = (heading,); y = (yaw_rate,): sample k + 1 if one is due at t, else the one held."""
    if not sample_due(t, x.t_last, p.period):
        return x, y
    rate = (u[0] - x.heading) / (t - x.t_last)
    return x, (rate + p.bias + p.noise_std * standard_normal(int(p.seed), int(x.k) + 1, 0),)


@kernel_function
def imu_step(t: float, h: float, x: ImuState, y: tuple, u: tuple, p: ImuParams
             ) -> tuple[ImuState, tuple]:
    """A sample due at t (or the first step's, sample 0) keeps its heading, time and index for
    the next."""
    first = math.isnan(x.t_last)
    if not (first or sample_due(t, x.t_last, p.period)):
        return x, y
    _, y = imu_evaluate(t, x, y, u, p)
    return ImuState(u[0], t, x.k if first else x.k + 1.0), y


class Imu(Component):
    """Yaw-rate gyro (rate-integrating): heading change per sample, plus bias and noise."""

    kind = "imu"
    bias = Parameter(0.0, unit="rad/s", description="constant bias")
    noise_std = Parameter(0.0, unit="rad/s", min=0.0,
                          description="standard deviation of each sample's Gaussian noise")
    seed = Parameter(0.0, min=0.0, max=SEED_MAX,
                     description="whole number: the noise sequence (the same in Python, "
                                 "compiled and C)")
    sample_period = Parameter(1e-3, unit="s", min=0.0,
                              description="period of the samples; 0 = every step")

    heading = Input(0.0, unit="rad", description="true heading theta (wire plant.pose[3])")
    yaw_rate = Output(0.0, unit="rad/s", depends_on=("heading",),
                      description="measured yaw rate, held over a sample period")

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.seed != int(self.seed):
            return [("seed", f"seed = {self.seed} is not a whole number.",
                     "give the seed as a whole number, e.g. 1.")]
        return []

    def initialize(self) -> None:
        p = self._params()
        self.yaw_rate = p.bias + p.noise_std * standard_normal(int(p.seed), 0, 0)

    def _params(self) -> ImuParams:
        return ImuParams(float(self.bias), float(self.noise_std), float(self.seed),
                         float(self.sample_period))

    def kernel(self, h: float) -> Kernel:
        """The gyro's definition (sample 0's heading not taken yet: the first step takes it)."""
        return Kernel(params=self._params(), state=ImuState(0.0, math.nan, 0.0),
                      evaluate=imu_evaluate, step=imu_step)


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
Imu.c_twin = CTwin(TWINS / "imu.c", headers=(SAMPLED, PHILOX),
                   tunable=frozenset({"bias", "noise_std", "sample_period"}), work=lambda comp: 3)
