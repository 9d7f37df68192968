"""The three-wheeled mobile robot with wheel slip: kinematics eqs (1)-(4), (11), dynamics eq. (8).

State: pose of the rear-axle midpoint M (x_M, y_M, theta) and wheel speeds nu = (phi_R', phi_L').
The model is integrated by classical RK4 with ceil(h / internal_step) equal substeps, compiled
with numba (`_model.rk4`). Torques are held over a step (the controller's zero-order hold). Slip
and disturbance are held too, unless `slip_model` is wired from a `slip_disturbance` block: the
plant then evaluates that profile at every RK4 stage, so the slip is continuous in time and
halving `internal_step` converges to the continuous-input solution (the held slip inputs are then
not used).

Implemented exactly as printed in the paper (docs/model.md lists our errata): B has no factor a
and m11 contains 2 m_W r^2. The centre of mass G is x_G = x_M + a cos(theta),
y_G = y_M + a sin(theta)
(eq. 4 minus eq. 11). `scale` multiplies every mass and inertia (m_G, m_W, I_G, I_D, I_W): the
paper runs the plant at +25 % (scale 1.25) against the controller's nominal values.
"""
from __future__ import annotations

import math

from twmr.components._model import DESCRIPTOR, inertia, njit, rk4
from twmr.core import Component, Input, Output, Parameter, State
from twmr.master.compiled import Kernel


@njit(cache=True, error_model="numpy")
def plant_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
               ) -> tuple[tuple, tuple]:
    """Kernel of `TwmrPlant.do_step`; p = (substeps, substep [s], m11, m12, q1, q2, m_G, a, r,
    b); u = (torque, slip_rate, slip_accel, disturbance, slip_model); y = (pose, wheel_speed,
    com)."""
    (px, py, th), (wR, wL) = y[0], y[1]
    tq, rate, acc, dist, model = u
    xn, yn, thn, wRn, wLn, xg, yg = rk4(
        int(p[0]), p[1], t, px, py, th, wR, wL, tq[0], tq[1], rate[0], rate[1], rate[2],
        acc[0], acc[1], acc[2], dist[0], dist[1], model, p[2], p[3], p[4], p[5], p[6], p[7],
        p[8], p[9])
    return x, ((xn, yn, thn), (wRn, wLn), (xg, yg))


class TwmrPlant(Component):
    """TWMR with wheel slip and disturbance torque, paper eqs (1)-(8), (11); Table I defaults."""

    kind = "twmr_plant"
    a = Parameter(0.3, unit="m", min=0.0, description="distance M to G (Table I)")
    I_G = Parameter(15.625, unit="kg.m2", min=0.0, description="platform inertia")
    I_D = Parameter(0.0025, unit="kg.m2", min=0.0, description="wheel inertia, diameter axis")
    I_W = Parameter(0.1, unit="kg.m2", min=0.0, description="wheel inertia, rotation axis")
    r = Parameter(0.15, unit="m", min=1e-6, description="wheel radius")
    b = Parameter(0.75, unit="m", min=1e-6, description="half track width (wheel to M)")
    m_W = Parameter(1.0, unit="kg", min=0.0, description="mass of each wheel")
    m_G = Parameter(30.0, unit="kg", min=1e-6, description="platform mass")
    scale = Parameter(1.0, min=1e-6, description="factor on every mass and inertia")
    internal_step = Parameter(1e-3, unit="s", min=1e-9, description="largest RK4 substep")

    torque = Input(size=2, unit="N.m", description="wheel torques (tau_R, tau_L)")
    slip_rate = Input(size=3, unit="m/s", description="(mu_R', mu_L', delta')")
    slip_accel = Input(size=3, unit="m/s2", description="(mu_R'', mu_L'', delta'')")
    disturbance = Input(size=2, unit="N.m", description="external disturbance tau_d")
    slip_model = Input(size=DESCRIPTOR, optional=True,
                       description="slip profile to evaluate inside the integration (wire "
                                   "slip.model here); unwired: the held slip inputs are used")

    pose = State((0.0, 0.0, 0.0), size=3, unit=("m", "m", "rad"), description="(x_M, y_M, theta)")
    wheel_speed = State((0.0, 0.0), size=2, unit="rad/s", description="(phi_R', phi_L')")
    com = Output(size=2, unit="m", description="centre of mass (x_G, y_G), eq. (4)")

    def initialize(self) -> None:
        k = self.scale
        self.m11, self.m12, self.q1, self.q2 = inertia(
            self.a, k * self.I_G, k * self.I_D, k * self.I_W, self.r, self.b, k * self.m_W,
            k * self.m_G)
        self.mG = k * self.m_G
        self._coef = self.coefficients
        self._h = 0.0
        rk4(0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
            0.0, tuple(self.slip_model), *self._coef)  # compiled kernel loaded now, not in
        # the first (maybe paced) step
        self._com()

    def kernel(self, h: float) -> Kernel:
        """The compiled form, for steps of h [s]."""
        n = max(1, math.ceil(h / self.internal_step - 1e-9))
        return Kernel(params=(float(n), h / n, *map(float, self._coef)), step=plant_step)

    @property
    def coefficients(self) -> tuple[float, ...]:
        """(m11, m12, q1, q2, m_G, a, r, b) as used by the model, after `scale`."""
        return (self.m11, self.m12, self.q1, self.q2, self.mG, self.a, self.r, self.b)

    def _com(self) -> None:
        x, y, th = self.pose
        self.com = (x + self.a * math.cos(th), y + self.a * math.sin(th))

    def do_step(self, t: float, h: float) -> None:
        if h != self._h:  # substeps for this step size
            self._n = max(1, math.ceil(h / self.internal_step - 1e-9))
            self._hs, self._h = h / self._n, h
        x, y, th, wR, wL, xg, yg = rk4(self._n, self._hs, t, *self.pose, *self.wheel_speed,
                                       *self.torque, *self.slip_rate, *self.slip_accel,
                                       *self.disturbance, self.slip_model, *self._coef)
        self.pose = (x, y, th)
        self.wheel_speed = (wR, wL)
        self.com = (xg, yg)
