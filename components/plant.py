"""The three-wheeled mobile robot with wheel slip: kinematics eqs (1)-(4), (11), dynamics eq. (8).

State: pose of the rear-axle midpoint M (x_M, y_M, theta) and wheel speeds nu = (phi_R', phi_L').
The model is integrated by classical RK4 with ceil(h / internal_step) equal substeps
(`_model.rk4`, compiled with numba in the compiled loop). Torques are held over a step (the
controller's zero-order hold). Slip and disturbance are held too, unless `slip_model` is wired
from a `slip_disturbance` block: the plant then evaluates that profile at every RK4 stage, so the
slip is continuous in time and halving `internal_step` converges to the continuous-input solution
(the held slip inputs are then not used).

Implemented exactly as printed in the paper (docs/model.md lists our errata): B has no factor a
and m11 contains 2 m_W r^2. The centre of mass G is x_G = x_M + a cos(theta),
y_G = y_M + a sin(theta)
(eq. 4 minus eq. 11). `scale` multiplies every mass and inertia (m_G, m_W, I_G, I_D, I_W): the
paper runs the plant at +25 % (scale 1.25) against the controller's nominal values.
"""
from __future__ import annotations

import math
from typing import Any, NamedTuple

from twmr.components._model import DESCRIPTOR, inertia, rk4
from twmr.components.ctwins import INERTIA, SLIP_DEFINES, SLIP_PROFILE
from twmr.components.ctwins import C as TWINS
from twmr.core import Component, Input, Output, Parameter, State
from twmr.core.ctwin import CTwin
from twmr.core.kernel import Kernel, kernel_function


class PlantParams(NamedTuple):
    """The plant's parameter table: RK4 substeps of a step and their size, the coefficients of
    eq. (8) after `scale`, and the geometry."""

    substeps: int
    substep: float  #: [s]
    m11: float  #: [kg.m2]
    m12: float
    q1: float  #: [kg.m]
    q2: float
    m_G: float  #: [kg]
    a: float  #: [m]
    r: float
    b: float


@kernel_function
def plant_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: PlantParams
               ) -> tuple[tuple, tuple]:
    """`TwmrPlant.do_step`: u = (torque, slip_rate, slip_accel, disturbance, slip_model);
    y = (pose, wheel_speed, com)."""
    (px, py, th), (wR, wL) = y[0], y[1]
    tq, rate, acc, dist, model = u
    xn, yn, thn, wRn, wLn, xg, yg = rk4(
        p.substeps, p.substep, t, px, py, th, wR, wL, tq[0], tq[1], rate[0], rate[1], rate[2],
        acc[0], acc[1], acc[2], dist[0], dist[1], model, p.m11, p.m12, p.q1, p.q2, p.m_G, p.a,
        p.r, p.b)
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

    def bodies(self) -> dict[str, dict[str, float]]:
        """The pose's vehicle, schematically: two wheels of radius r at +-b from M, a platform
        between them reaching from M to G (a) and a little beyond."""
        r, b, a = float(self.r), float(self.b), float(self.a)
        return {"pose": {"wheel_radius": r, "half_track": b, "length": a + 2.0 * r,
                         "width": max(2.0 * b - 0.2, 0.1), "height": 0.5 * r, "ahead": a / 2}}

    def vectors(self) -> dict[str, list[dict[str, Any]]]:
        """On the pose's vehicle: each wheel's longitudinal slip velocity mu' (0.25 m per m/s,
        at the wheel's contact point, along x), the lateral slip velocity delta' of M (along y)
        and each wheel's disturbance torque tau_d (0.2 m per N.m, at the wheel's top, along x);
        slip magenta, disturbance green."""
        r, b = float(self.r), float(self.b)
        slip, torque = 0.25, 0.2
        return {"pose": [
            {"label": "slip mu_R'", "port": "slip_rate", "element": 0, "at": (0.0, -b, 0.0),
             "along": (1.0, 0.0, 0.0), "scale": slip, "colour": "#CC00CC"},
            {"label": "slip mu_L'", "port": "slip_rate", "element": 1, "at": (0.0, b, 0.0),
             "along": (1.0, 0.0, 0.0), "scale": slip, "colour": "#CC00CC"},
            {"label": "slip delta'", "port": "slip_rate", "element": 2, "at": (0.0, 0.0, 0.0),
             "along": (0.0, 1.0, 0.0), "scale": slip, "colour": "#CC00CC"},
            {"label": "tau_d R", "port": "disturbance", "element": 0, "at": (0.0, -b, 2 * r),
             "along": (1.0, 0.0, 0.0), "scale": torque},
            {"label": "tau_d L", "port": "disturbance", "element": 1, "at": (0.0, b, 2 * r),
             "along": (1.0, 0.0, 0.0), "scale": torque}]}

    def initialize(self) -> None:
        k = self.scale
        self.m11, self.m12, self.q1, self.q2 = inertia(
            self.a, k * self.I_G, k * self.I_D, k * self.I_W, self.r, self.b, k * self.m_W,
            k * self.m_G)
        # no RK4 step: the centre of mass at the start, and the compiled model loaded now, not
        # in the first (maybe paced) step
        *_, xg, yg = rk4(0, 0.0, self.start_time, *self.pose, *self.wheel_speed, 0.0, 0.0, 0.0,
                         0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, tuple(self.slip_model),
                         *self.params(1.0)[2:])
        self.com = (xg, yg)

    def params(self, h: float) -> PlantParams:
        """The parameter table for steps of h [s] (after `initialize`)."""
        n = max(1, math.ceil(h / self.internal_step - 1e-9))
        return PlantParams(n, h / n, float(self.m11), float(self.m12), float(self.q1),
                           float(self.q2), float(self.scale * self.m_G), float(self.a),
                           float(self.r), float(self.b))

    def kernel(self, h: float) -> Kernel:
        """The plant's definition, for steps of h [s]."""
        return Kernel(params=self.params(h), step=plant_step)


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
TwmrPlant.c_twin = CTwin(TWINS / "plant.c", headers=(INERTIA, SLIP_PROFILE),
                         defines=SLIP_DEFINES, work=lambda comp: 8)
