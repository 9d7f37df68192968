"""What the ASMC and the SMC share: ports, nominal model, gains and the law of eqs (9)-(32).

The controller samples its inputs at each communication point t and outputs the torque for
[t, t + h) (direct feedthrough: `evaluate` computes it). x2 is formed without the slip, which the
paper says is unmeasured: x1' = kappa nu + R(theta) p_T' (eq. 15 with xi_1's slip terms dropped).

Singularity (det kappa = -r^2 e_p1 / (2b)): the law is applied to a look-ahead point P = M + L
(cos theta, sin theta) on the body axis, x1 = e_p - [L, 0] (docs/model.md). kappa is unchanged
(the same matrix for that point), and the equilibrium e_p1 = L lies off the singular line; the
cost is a steady offset of about |L| between M and T. Which sign is stable depends on the motion:
the default L = -0.05 m (5 cm behind M) is the one every shipped scenario uses; with +0.05 m
trajectory 1 settles only at 29 s (MSE_x 0.053 against 0.0104; `twmr run
scenarios/paper_trajectory1_asmc.yaml --set ctrl.lookahead=0.05 --metrics tracking`). A
sign-preserving clamp |e_p1| >= eps_singular in kappa keeps tau finite even at e_p1 = 0 exactly
(during the transient). `lookahead = 0` gives the law exactly as printed (with the clamp only).
"""
from __future__ import annotations

from twmr.components._model import inertia, tracking_law
from twmr.core import Component, Input, Output, Parameter


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
    vartheta = Parameter(20.0, unit="1/s", min=0.0, description="sliding surface s = vartheta x1 + x2")
    k = Parameter(20.0, min=0.0, description="switching gain, eq. (32)")
    lookahead = Parameter(-0.05, unit="m", description="look-ahead L of the tracked point "
                                                        "(negative: behind M)")
    eps_singular = Parameter(1e-3, unit="m", min=1e-12, description="clamp of |e_p1| in kappa")
    phi = Parameter(0.0, min=0.0, description="boundary layer: sat(s/phi) instead of sgn(s); 0 = sgn")
    torque_limit = Parameter(0.0, unit="N.m", min=0.0, description="|tau| limit; 0 = none")

    pose = Input(size=3, unit=("m", "m", "rad"), description="(x_M, y_M, theta)")
    wheel_speed = Input(size=2, unit="rad/s", description="nu = (phi_R', phi_L')")
    ref_position = Input(size=2, unit="m", description="(x_T, y_T)")
    ref_velocity = Input(size=2, unit="m/s", description="(x_T', y_T')")
    ref_acceleration = Input(size=2, unit="m/s2", description="(x_T'', y_T''); unused by the law")

    _deps = ("pose", "wheel_speed", "ref_position", "ref_velocity", "ref_acceleration")
    torque = Output(size=2, unit="N.m", depends_on=_deps, description="(tau_R, tau_L), eq. (32)")
    error = Output(size=2, unit="m", depends_on=_deps, description="e_p of M, eq. (9)")
    s = Output(size=2, depends_on=_deps, description="sliding variable, eq. (25)")

    def initialize(self) -> None:
        self.m11, self.m12, _, _ = inertia(self.a, self.I_G, self.I_D, self.I_W, self.r, self.b,
                                           self.m_W, self.m_G)
        self._gains = (self.m11, self.m12, self.m_G, self.r, self.b, self.lam, self.vartheta,
                       self.k, self.lookahead, self.eps_singular, self.phi)
        self.evaluate(self.start_time)

    def adaptive_term(self) -> tuple[float, float]:
        """d_hat of eq. (32); zero for plain SMC."""
        return 0.0, 0.0

    def evaluate(self, t: float) -> None:
        tR, tL, s1, s2, e1, e2 = tracking_law(
            *self.pose, *self.wheel_speed, *self.ref_position, *self.ref_velocity,
            *self.adaptive_term(), *self._gains)
        lim = self.torque_limit
        if lim > 0.0:
            tR, tL = min(lim, max(-lim, tR)), min(lim, max(-lim, tL))
        self.torque = (tR, tL)
        self.s = (s1, s2)
        self.error = (e1, e2)
