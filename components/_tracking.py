"""What the ASMC and the SMC share: ports, nominal model, gains and the law of eqs (9)-(32).

The controller samples its inputs at each communication point t and outputs the torque for
[t, t + h) (direct feedthrough: `evaluate` computes it). x2 is formed without the slip, which the
paper says is unmeasured: x1' = kappa nu + R(theta) p_T' (eq. 15 with xi_1's slip terms dropped).

Singularity (det kappa = -r^2 e_p1 / (2b)): the law is applied to a look-ahead point P = M + L
(cos theta, sin theta) on the body axis, x1 = e_p - [L, 0] (docs/model.md). kappa is unchanged
(the same matrix for that point), and the equilibrium e_p1 = L lies off the singular line; the
cost is a steady offset of about |L| between M and T. The stable side is the one where L and the
target's body-frame speed share a sign, i.e. the robot's driving direction: `drive: forward` puts
P ahead of M (L = +lookahead), `backward` behind it, `auto` chooses at the start (see
`start_direction`). A sign-preserving clamp |e_p1| >= eps_singular in kappa (and so in the x1'
estimate) keeps tau finite at e_p1 = 0. With eps_singular above the |e_p1| the loop runs at (the
shipped configurations: 0.5 m and 0.81 m, against |e_p1| of a few cm) the clamp is active nearly
all the time, not only in the transient: it is a lasting change of the law, a fixed lever arm
of eps_singular in kappa (docs/model.md, section 3, measures how often and what it changes).
`lookahead = 0` gives the law as printed with the clamp only.

Actuation: each wheel's torque is limited to `torque_limit` (the drive's 48 N.m by default; 0 = no
limit), by clipping each wheel or by scaling both. The defaults (eta in asmc, eps_singular, phi,
torque_limit) are the bounded-torque configuration of docs/reproduction.md, not Table II's.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from twmr.components._model import inertia, tracking_law
from twmr.core import STRING, Component, Input, Output, Parameter
from twmr.core.kernel import Kernel, kernel_function

#: drive sides and saturations, name -> code
DRIVES = {"auto": 0, "forward": 1, "backward": 2}
CLIP, SCALE = 0, 1
SATURATIONS = {"clip": CLIP, "scale": SCALE}


class LawParams(NamedTuple):
    """The parameter table of the law (`tracking_law`) and of the torque limit: the nominal model,
    the gains, the signed look-ahead L of the drive side chosen at `initialize`."""

    m11: float  #: [kg.m2]
    m12: float
    m_G: float  #: [kg]
    r: float  #: [m]
    b: float
    lam: float  #: [1/s]
    vartheta: float  #: [1/s]
    k: float
    L: float  #: [m]
    eps_singular: float  #: [m]
    phi: float
    torque_limit: float  #: [N.m]; 0: none
    saturation: float  #: SATURATIONS


class TrackingState(NamedTuple):
    """The controllers' private state."""

    saturated: float  #: 1.0 when the last torque was limited, else 0.0


@kernel_function
def limit_torque(lim: float, saturation: float, tR: float, tL: float
                 ) -> tuple[float, float, float]:
    """(tau_R, tau_L, saturated 0/1): the torque limit `lim` (0: none), by clipping each wheel
    or (`saturation` SCALE) scaling both."""
    saturated = lim > 0.0 and (abs(tR) > lim or abs(tL) > lim)
    if saturated:
        if saturation == SCALE:
            f = lim / max(abs(tR), abs(tL))
            tR, tL = tR * f, tL * f
        else:
            tR, tL = min(lim, max(-lim, tR)), min(lim, max(-lim, tL))
    return tR, tL, 1.0 if saturated else 0.0


@kernel_function
def limited_law(u: tuple, p: LawParams, dR: float, dL: float
                ) -> tuple[float, float, float, float, float, float, float]:
    """(tau_R, tau_L, s_1, s_2, e_p1, e_p2, saturated 0/1) from u = (pose, wheel_speed,
    ref_position, ref_velocity, ref_acceleration) and the adaptive term (dR, dL): the law, then
    the torque limit."""
    (x, y, th), (wR, wL), (xT, yT), (vxT, vyT) = u[0], u[1], u[2], u[3]
    tR, tL, s1, s2, e1, e2 = tracking_law(x, y, th, wR, wL, xT, yT, vxT, vyT, dR, dL, p.m11,
                                          p.m12, p.m_G, p.r, p.b, p.lam, p.vartheta, p.k, p.L,
                                          p.eps_singular, p.phi)
    tR, tL, saturated = limit_torque(p.torque_limit, p.saturation, tR, tL)
    return tR, tL, s1, s2, e1, e2, saturated


@kernel_function
def smc_evaluate(t: float, x: TrackingState, y: tuple, u: tuple, p: LawParams
                 ) -> tuple[TrackingState, tuple]:
    """The SMC's `evaluate`: y = (torque, error, s)."""
    tR, tL, s1, s2, e1, e2, sat = limited_law(u, p, 0.0, 0.0)
    x = x if sat == x.saturated else TrackingState(sat)
    return x, ((tR, tL), (e1, e2), (s1, s2))


class TrackingController(Component):
    """Sliding-mode tracking controller of the paper (shared part); subclasses add adaptation."""

    # nominal model (Table I)
    a = Parameter(0.3, unit="m", min=0.0)
    I_G = Parameter(15.625, unit="kg.m2", min=0.0)
    I_D = Parameter(0.0025, unit="kg.m2", min=0.0)
    I_W = Parameter(0.1, unit="kg.m2", min=0.0)
    r = Parameter(0.15, unit="m", min=1e-6)
    b = Parameter(0.75, unit="m", min=1e-6)
    m_W = Parameter(1.0, unit="kg", min=0.0)
    m_G = Parameter(30.0, unit="kg", min=1e-6)
    # gains (Table II)
    lam = Parameter(13.0, unit="1/s", min=0.0, description="lambda, x2 = x1' + lambda x1")
    vartheta = Parameter(20.0, unit="1/s", min=0.0,
                         description="sliding surface s = vartheta x1 + x2")
    k = Parameter(20.0, min=0.0, description="switching gain, eq. (32)")
    lookahead = Parameter(0.05, unit="m", min=0.0,
                          description="distance |L| of the tracked point from M on the body axis")
    drive = Parameter("auto", type=STRING,
                      description="forward: the point ahead of M (L > 0) | backward: behind | "
                                  "auto: chosen at the start from where the target goes")
    eps_singular = Parameter(0.5, unit="m", min=1e-12, description="clamp of |e_p1| in kappa")
    phi = Parameter(0.2, min=0.0,
                    description="boundary layer: sat(s/phi) instead of sgn(s); 0 = sgn")
    torque_limit = Parameter(48.0, unit="N.m", min=0.0,
                             description="|tau| limit of each wheel (the drive's); 0 = none")
    saturation = Parameter("clip", type=STRING,
                           description="clip: each wheel to the limit | scale: both wheels by one "
                                       "factor (keeps the direction of tau)")

    pose = Input(size=3, unit=("m", "m", "rad"), description="(x_M, y_M, theta)")

    def limits(self) -> dict[str, tuple[float, float]]:
        """The wheel torques within +-torque_limit (when there is one)."""
        limit = float(self.torque_limit)
        return {"torque": (-limit, limit)} if limit > 0 else {}
    wheel_speed = Input(size=2, unit="rad/s", description="nu = (phi_R', phi_L')")
    ref_position = Input(size=2, unit="m", description="(x_T, y_T)")
    ref_velocity = Input(size=2, unit="m/s", description="(x_T', y_T')")
    ref_acceleration = Input(size=2, unit="m/s2", description="(x_T'', y_T''); unused by the law")

    _deps = ("pose", "wheel_speed", "ref_position", "ref_velocity", "ref_acceleration")
    torque = Output(size=2, unit="N.m", depends_on=_deps, description="(tau_R, tau_L), eq. (32)")
    error = Output(size=2, unit="m", depends_on=_deps, description="e_p of M, eq. (9)")
    s = Output(size=2, depends_on=_deps, description="sliding variable, eq. (25)")

    def initialize(self) -> None:
        if self.saturation not in SATURATIONS:
            raise ValueError(f"unknown saturation '{self.saturation}'; use 'clip' or 'scale'")
        if self.drive not in DRIVES:
            raise ValueError(f"unknown drive '{self.drive}'; use 'auto', 'forward' or 'backward'")
        self.direction = self.drive if self.drive != "auto" else self.start_direction()
        self.m11, self.m12, _, _ = inertia(self.a, self.I_G, self.I_D, self.I_W, self.r, self.b,
                                           self.m_W, self.m_G)
        self.evaluate(self.start_time)

    def law_params(self) -> LawParams:
        """The law's table (after `initialize`: the nominal M and the drive side)."""
        L = self.lookahead if self.direction == "forward" else -self.lookahead
        lam, vartheta, k, phi = self.sliding_gains()
        return LawParams(float(self.m11), float(self.m12), float(self.m_G), float(self.r),
                         float(self.b), lam, vartheta, k, float(L), float(self.eps_singular),
                         phi, float(self.torque_limit), float(SATURATIONS[self.saturation]))

    def sliding_gains(self) -> tuple[float, float, float, float]:
        """(lambda, vartheta, k, phi) of the sliding-mode law."""
        return float(self.lam), float(self.vartheta), float(self.k), float(self.phi)

    def kernel(self, h: float) -> Kernel:
        """The SMC's definition (no adaptation); the ASMC gives its own."""
        return Kernel(params=self.law_params(), state=TrackingState(0.0), evaluate=smc_evaluate)

    def start_direction(self) -> str:
        """'forward' when the target, one second ahead, lies in front of M along the body axis
        (e_p1 + v_T1 * 1 s >= 0, eq. 9 with the target's velocity), else 'backward'."""
        x, y, th = self.pose
        (xT, yT), (vx, vy) = self.ref_position, self.ref_velocity
        c, s = math.cos(th), math.sin(th)
        ahead = c * (xT - x) + s * (yT - y) + (c * vx + s * vy) * 1.0
        return "forward" if ahead >= 0.0 else "backward"
