"""An LQR (or LQI) tracking controller on the error model of the look-ahead point the sliding-mode
laws use, for comparing a linear-optimal law with the ASMC on equal terms.

Under the computed-torque part of eq. (32), tau = -Z^-1 v with v = E x1' + u_lqr, the error of the
look-ahead point obeys x1'' = -u_lqr + (the terms every law here treats as disturbance: the target's
acceleration, kappa' nu, the slip): two decoupled double integrators, the linearised error model. On
it, with the state (z, x1, x1') per axis (z = the integral of x1, present when `q_integral` > 0),
the cost integral of q_integral z^2 + q_position x1^2 + q_velocity x1'^2 + u^2 gives the gains u_lqr
= k_i z + k_p x1 + k_d x1' (`lqr_gains`: the LQR of that model, by spectral factorisation; without
the integral, in closed form k_p = sqrt(q_position), k_d = sqrt(2 k_p + q_velocity)). The C twin
(c/lqr.c) computes them by the same operations. The error model, the look-ahead point, its clamp,
the drive side and the torque limit are those of `_tracking` (shared with the SMC and the ASMC); the
integral is held while the torque is limited (anti-windup), as the ASMC holds d_hat.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from twmr.components._model import look_ahead_model, torque_for
from twmr.components._tracking import LawParams, TrackingController, limit_torque
from twmr.components.ctwins import DRIVES, INERTIA, LOOK_AHEAD, TRACKING
from twmr.components.ctwins import C as TWINS
from twmr.core import Output, Parameter
from twmr.core.ctwin import CTwin
from twmr.core.kernel import Kernel, kernel_function


class LqrParams(NamedTuple):
    """The law's table (the gains of the sliding-mode laws unused) and the LQR gains."""

    law: LawParams
    k_i: float  #: [1/s3]
    k_p: float  #: [1/s2]
    k_d: float  #: [1/s]


class LqrState(NamedTuple):
    saturated: float  #: 1.0 when the last torque was limited, else 0.0


def lqr_gains(q_integral: float, q_position: float, q_velocity: float
              ) -> tuple[float, float, float]:
    """(k_i, k_p, k_d) of u = k_i z + k_p x + k_d x' minimising the integral of q_integral z^2 +
    q_position x^2 + q_velocity x'^2 + u^2 for x'' = -u, z' = x.

    By spectral factorisation: the optimal closed loop's polynomial s^3 + a s^2 + b s + c
    satisfies Delta(s) Delta(-s) = -s^6 + q_velocity s^4 - q_position s^2 + q_integral (the
    return-difference identity for the integrator chain), i.e. c^2 = q_integral,
    a^2 - 2 b = q_velocity, b^2 - 2 a c = q_position: c = sqrt(q_integral), b = (a^2 -
    q_velocity) / 2 and a the root above sqrt(q_velocity) of (a^2 - q_velocity)^2 - 4 q_position -
    8 c a, convex there, found by Newton's method from its right (the C twin does the same
    operations). It holds for any weights >= 0, where a Riccati solver fails on tiny ones."""
    c = math.sqrt(q_integral)
    a = math.sqrt(q_velocity + 2.0 * math.sqrt(q_position))  # the root for c = 0
    if c > 0.0:
        a = max(a, 1.0)
        while (a * a - q_velocity) * (a * a - q_velocity) - 4.0 * q_position - 8.0 * c * a <= 0.0:
            a = 2.0 * a
        for _ in range(200):
            w = a * a - q_velocity
            step = (w * w - 4.0 * q_position - 8.0 * c * a) / (4.0 * a * w - 8.0 * c)
            if not a - step < a:
                break
            a = a - step
    return c, 0.5 * (a * a - q_velocity), a


@kernel_function
def lqr_evaluate(t: float, x: LqrState, y: tuple, u: tuple, p: LqrParams
                 ) -> tuple[LqrState, tuple]:
    """y = (torque, error, integral): tau = -Z^-1 (E x1' + k_i z + k_p x1 + k_d x1'), limited."""
    (px, py, th), (wR, wL), (xT, yT), (vxT, vyT) = u[0], u[1], u[2], u[3]
    q = p.law
    (e1, e2, x11, x12, d11, d12, z11, z12, z21, z22, E11, E12, E21,
     E22) = look_ahead_model(px, py, th, wR, wL, xT, yT, vxT, vyT, q.m11, q.m12, q.m_G, q.r, q.b,
                             q.L, q.eps_singular)
    i1, i2 = y[2]
    v1 = (p.k_d + E11) * d11 + E12 * d12 + p.k_p * x11 + p.k_i * i1
    v2 = E21 * d11 + (p.k_d + E22) * d12 + p.k_p * x12 + p.k_i * i2
    tR, tL = torque_for(v1, v2, z11, z12, z21, z22)
    tR, tL, sat = limit_torque(q.torque_limit, q.saturation, tR, tL)
    x = x if sat == x.saturated else LqrState(sat)
    return x, ((tR, tL), (e1, e2), y[2])


@kernel_function
def lqr_advance(t: float, h: float, x: LqrState, y: tuple, u: tuple, p: LqrParams
                ) -> tuple[LqrState, tuple]:
    """z += x1 h with x1 held over the step (x1 = e_p - [L, 0]), held while saturated."""
    if p.k_i != 0.0 and x.saturated == 0.0:
        e1, e2 = y[1]
        i1, i2 = y[2]
        y = (y[0], y[1], (i1 + (e1 - p.law.L) * h, i2 + e2 * h))
    return x, y


@kernel_function
def lqr_step(t: float, h: float, x: LqrState, y: tuple, u: tuple, p: LqrParams
             ) -> tuple[LqrState, tuple]:
    """`lqr_advance`, then the outputs at t + h with the inputs held."""
    x, y = lqr_advance(t, h, x, y, u, p)
    return lqr_evaluate(t + h, x, y, u, p)


class LqrController(TrackingController):
    """LQR / LQI tracking controller on the look-ahead point's linearised error model."""

    kind = "lqr"
    q_position = Parameter(1e5, unit="1/s4", min=0.0,
                           description="weight of the look-ahead point's error x1 (u weighs 1)")
    q_velocity = Parameter(1e4, unit="1/s2", min=0.0, description="weight of x1'")
    q_integral = Parameter(0.0, unit="1/s6", min=0.0,
                           description="weight of the integral of x1; 0 = LQR, > 0 = LQI")
    integral = Output(size=2, unit="m.s", description="the integral of x1 (LQI state)")
    torque = Output(size=2, unit="N.m", depends_on=TrackingController._deps,
                    description="(tau_R, tau_L) = -Z^-1 (E x1' + k_i z + k_p x1 + k_d x1')")
    error = Output(size=2, unit="m", depends_on=TrackingController._deps,
                   description="e_p of M, eq. (9)")
    # the sliding-mode laws' own: no sliding variable, no lambda, vartheta, k nor phi
    s = lam = vartheta = k = phi = None

    def initialize(self) -> None:
        if float(self.q_position) <= 0.0:
            raise ValueError("q_position must be above 0 (the error's weight); give e.g. 1e5")
        self.integral = (0.0, 0.0)
        super().initialize()

    def sliding_gains(self) -> tuple[float, float, float, float]:
        """None: this law has no sliding-mode gains (0 in the shared table, unused)."""
        return 0.0, 0.0, 0.0, 0.0

    def gains(self) -> tuple[float, float, float]:
        """(k_i, k_p, k_d) from the weights (`lqr_gains`)."""
        return lqr_gains(float(self.q_integral), float(self.q_position), float(self.q_velocity))

    def kernel(self, h: float) -> Kernel:
        """The LQR's definition."""
        k_i, k_p, k_d = self.gains()
        return Kernel(params=LqrParams(self.law_params(), k_i, k_p, k_d), state=LqrState(0.0),
                      evaluate=lqr_evaluate, step=lqr_step, advance=lqr_advance)


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
LqrController.c_twin = CTwin(
    TWINS / "lqr.c", headers=(INERTIA, LOOK_AHEAD),
    tunable=frozenset(("lookahead", "eps_singular", "torque_limit", "q_position", "q_velocity",
                       "q_integral")),
    choices=TRACKING, defines=DRIVES, work=lambda comp: 10)
