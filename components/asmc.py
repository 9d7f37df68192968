"""Adaptive sliding-mode controller (ASMC) of the paper, eqs (9)-(33); its defaults are the
bounded-torque configuration of docs/reproduction.md, not Table II's gains.

tau = -Z^-1 [(vartheta I + E)(x2 - lambda x1) + d_hat + k sgn(s)]   (eq. 32)
d_hat' = eta s                                                       (eq. 33)
with Z = kappa M^-1, E = -kappa M^-1 B kappa^-1 from the nominal model. How x2 is formed and how
the singularity of kappa is handled: see `_tracking` (x1' without slip; look-ahead point L and a
clamp of |e_p1|, which with the shipped eps_singular is active nearly all the time). d_hat is
integrated exactly for s held over the step: d_hat += eta s h.
"""
from __future__ import annotations

from typing import NamedTuple

from twmr.components._tracking import LawParams, TrackingController, TrackingState, limited_law
from twmr.components.ctwins import DRIVES, GAINS, INERTIA, LOOK_AHEAD, TRACKING
from twmr.components.ctwins import C as TWINS
from twmr.core import BOOLEAN, Output, Parameter
from twmr.core.ctwin import Choice, CTwin
from twmr.core.kernel import Kernel, kernel_function


class AsmcParams(NamedTuple):
    """The ASMC's parameter table: the law's, and the adaptation's."""

    law: LawParams
    eta: float  #: adaptation gain, eq. (33)
    d_hat_limit: float  #: projection |d_hat_i| <= this; 0: none
    hold_saturated: float  #: 1.0: hold d_hat while the torque is limited


@kernel_function
def asmc_evaluate(t: float, x: TrackingState, y: tuple, u: tuple, p: AsmcParams
                  ) -> tuple[TrackingState, tuple]:
    """`AsmcController.evaluate`: y = (torque, error, s, d_hat)."""
    dR, dL = y[3]
    tR, tL, s1, s2, e1, e2, sat = limited_law(u, p.law, dR, dL)
    x = x if sat == x.saturated else TrackingState(sat)
    return x, ((tR, tL), (e1, e2), (s1, s2), y[3])


@kernel_function
def asmc_advance(t: float, h: float, x: TrackingState, y: tuple, u: tuple, p: AsmcParams
                 ) -> tuple[TrackingState, tuple]:
    """d_hat by eq. (33), held while saturated (anti-windup), clamped to the projection."""
    if not (x.saturated == 1.0 and p.hold_saturated == 1.0):
        s1, s2 = y[2]
        d1, d2 = y[3]
        d1, d2 = d1 + p.eta * s1 * h, d2 + p.eta * s2 * h  # eq. (33)
        m = p.d_hat_limit
        if m > 0.0:
            d1, d2 = min(m, max(-m, d1)), min(m, max(-m, d2))
        y = (y[0], y[1], y[2], (d1, d2))
    return x, y


@kernel_function
def asmc_step(t: float, h: float, x: TrackingState, y: tuple, u: tuple, p: AsmcParams
              ) -> tuple[TrackingState, tuple]:
    """`AsmcController.do_step`: `asmc_advance`, then the outputs at t + h with the inputs
    held, as its C FMU reports them after fmi2DoStep (what a Jacobi master passes on)."""
    x, y = asmc_advance(t, h, x, y, u, p)
    return asmc_evaluate(t + h, x, y, u, p)


class AsmcController(TrackingController):
    """ASMC, paper eqs (9)-(33): sliding-mode law with the adaptive estimate d_hat of eq. (33)."""

    kind = "asmc"
    eta = Parameter(0.1, min=0.0, description="adaptation gain, eq. (33) (Table II: 7)")
    d_hat0 = Parameter((0.0, 0.0), size=2, unit="m/s2",
                       description="initial adaptive estimate d_hat(0)")
    d_hat_limit = Parameter(0.0, unit="m/s2", min=0.0,
                            description="projection: |d_hat_i| <= this; 0 = none")
    hold_saturated = Parameter(True, type=BOOLEAN,
                               description="anti-windup: hold d_hat while the torque is limited")
    d_hat = Output(size=2, unit="m/s2", description="adaptive estimate of d, eq. (33): an "
                   "acceleration of the look-ahead point, as each term of eq. (32)")

    def initialize(self) -> None:
        self.d_hat = tuple(self.d_hat0)
        super().initialize()

    def kernel(self, h: float) -> Kernel:
        """The ASMC's definition."""
        return Kernel(params=AsmcParams(self.law_params(), float(self.eta),
                                        float(self.d_hat_limit),
                                        1.0 if self.hold_saturated else 0.0),
                      state=TrackingState(0.0), evaluate=asmc_evaluate, step=asmc_step,
                      advance=asmc_advance)


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
AsmcController.c_twin = CTwin(
    TWINS / "tracking.c", headers=(INERTIA, LOOK_AHEAD),
    tunable=frozenset((*GAINS, "eta", "d_hat_limit")),
    choices={**TRACKING, "hold_saturated": Choice("HOLD_SATURATED", {True: 1, False: 0})},
    defines={**DRIVES, "ADAPTIVE": 1}, work=lambda comp: 4)
