"""Motor driver of each wheel: torque command in; applied torque, measured speed and angle out.

`mode: ideal` applies the command exactly (the paper's assumption), limited to `torque_max` per
wheel when that is set. `mode: dc` models a geared DC
motor per wheel with a PI current loop:

    L di/dt = V - R i - K_e N omega_wheel        (armature; N = gear ratio)
    tau_wheel = eta_g N K_t i                    (applied torque)
    i_ref = clamp(tau_cmd / (eta_g N K_t), +-I_max)
    V = clamp(K_p (i_ref - i) + K_i z, +-V_max), z' = i_ref - i (integration held while saturated)

The armature is discretised exactly for a voltage and speed held over the component's step
(zero-order hold, `armature_zoh`: a = exp(-R h / L), b_V = (1 - a) / R, b_omega = -K_e N b_V;
again whenever the step changes); the PI law runs at that step. Default PI gains place the
current loop at `bandwidth` [rad/s]: K_p = L bandwidth, K_i = R bandwidth. Defaults: a 24 V,
~250 W geared motor (R 0.3 Ohm, L 0.3 mH, K_t = K_e = 0.06, N = 20, I_max 40 A: 48 N.m at the
wheel).

Measured speed and angle are sampled at the end of each step from the wheel speed input held over
it (an encoder), so they do not depend directly on inputs.

A command beyond twice the drive's limit (I_max eta_g N K_t in `dc` mode; in `ideal` mode
`torque_max`, or `rated_torque` when no limit is set and the command is applied anyway) is
implausible for the robot: the run's output warns about the first one, once.
"""
from __future__ import annotations

import logging
import math
from typing import NamedTuple

from twmr.components.ctwins import C as TWINS
from twmr.core import STRING, Component, Input, Output, Parameter
from twmr.core.ctwin import Choice, CTwin
from twmr.core.kernel import Kernel, kernel_function

#: modes, name -> code (`MotorParams.dc`)
MODES = {"ideal": 0, "dc": 1}


class MotorParams(NamedTuple):
    """The motor driver's parameter table (the zoh coefficients are those of the step h)."""

    dc: float  #: MODES
    torque_max: float  #: ideal mode's limit [N.m]; 0: none
    kt: float  #: eta_g N K_t [N.m/A]
    kp: float  #: [V/A]
    ki: float  #: [V/(A.s)]
    i_max: float  #: [A]
    v_max: float  #: [V]
    a: float  #: armature_zoh
    b_v: float  #: [A/V]
    b_w: float  #: [A.s/rad]


class MotorState(NamedTuple):
    """The motor driver's private state."""

    i_R: float  #: armature currents [A]
    i_L: float
    z_R: float  #: PI integrals [A.s]
    z_L: float
    implausible: float  #: |command| beyond this is warned about [N.m] (inf once it was)
    t_implausible: float  #: time of the first implausible command [s]; nan: none
    c_R: float  #: that command [N.m]
    c_L: float


def armature_zoh(R: float, L: float, K_e: float, gear: float, h: float
                 ) -> tuple[float, float, float]:
    """(a, b_V, b_omega) of L di/dt = V - R i - K_e N omega discretised exactly for V and omega
    held over h [s] (zero-order hold): i(t + h) = a i + b_V V + b_omega omega."""
    a = math.exp(-R * h / L)
    b_v = -math.expm1(-R * h / L) / R
    return a, b_v, -K_e * gear * b_v


@kernel_function
def motor_evaluate(t: float, x: MotorState, y: tuple, u: tuple, p: MotorParams
                   ) -> tuple[MotorState, tuple]:
    """`MotorDriver.evaluate`: u = (torque_command, wheel_speed); y = (torque, measured_speed,
    angle)."""
    c = u[0]
    if abs(c[0]) > x.implausible or abs(c[1]) > x.implausible:
        x = MotorState(x.i_R, x.i_L, x.z_R, x.z_L, math.inf, t, c[0], c[1])
    if p.dc == 0.0:
        m = p.torque_max
        torque = (min(m, max(-m, c[0])), min(m, max(-m, c[1]))) if m > 0.0 else c
    else:
        torque = (p.kt * x.i_R, p.kt * x.i_L)
    return x, (torque, y[1], y[2])


@kernel_function
def motor_step(t: float, h: float, x: MotorState, y: tuple, u: tuple, p: MotorParams
               ) -> tuple[MotorState, tuple]:
    """`MotorDriver.do_step`: the encoder, and in dc mode the PI current loop and the armature."""
    c, w = u[0], u[1]
    a0, a1 = y[2]
    angle = (a0 + w[0] * h, a1 + w[1] * h)
    if p.dc == 0.0:
        return x, (y[0], w, angle)
    kt, kp, ki, imax, vmax = p.kt, p.kp, p.ki, p.i_max, p.v_max
    i0, i1, z0, z1 = x.i_R, x.i_L, x.z_R, x.z_L
    i_ref = min(imax, max(-imax, c[0] / kt))
    err = i_ref - i0
    v_raw = kp * err + ki * z0
    v = min(vmax, max(-vmax, v_raw))
    if v == v_raw:  # anti-windup: hold the integral while saturated
        z0 += err * h
    i0 = p.a * i0 + p.b_v * v + p.b_w * w[0]
    i_ref = min(imax, max(-imax, c[1] / kt))
    err = i_ref - i1
    v_raw = kp * err + ki * z1
    v = min(vmax, max(-vmax, v_raw))
    if v == v_raw:
        z1 += err * h
    i1 = p.a * i1 + p.b_v * v + p.b_w * w[1]
    return (MotorState(i0, i1, z0, z1, x.implausible, x.t_implausible, x.c_R, x.c_L),
            ((kt * i0, kt * i1), w, angle))


class MotorDriver(Component):
    """Two wheel drives: ideal torque source or geared DC motor with a PI current loop."""

    kind = "motor_driver"
    mode = Parameter("ideal", type=STRING, description=" | ".join(MODES))
    R = Parameter(0.3, unit="Ohm", min=1e-9, description="armature resistance")
    L = Parameter(3e-4, unit="H", min=1e-12, description="armature inductance")
    K_t = Parameter(0.06, unit="N.m/A", min=1e-12, description="torque constant")
    K_e = Parameter(0.06, unit="V.s/rad", min=0.0, description="back-EMF constant")
    gear = Parameter(20.0, min=1e-12, description="gear ratio N (motor turns per wheel turn)")
    efficiency = Parameter(1.0, min=0.0, max=1.0, description="gear efficiency eta_g")
    V_max = Parameter(24.0, unit="V", min=0.0, description="supply voltage (PWM saturation)")
    I_max = Parameter(40.0, unit="A", min=0.0, description="current limit")
    bandwidth = Parameter(2000.0, unit="rad/s", min=0.0, description="current loop bandwidth")
    torque_max = Parameter(0.0, unit="N.m", min=0.0,
                           description="ideal mode: applied |torque| limit of each wheel; 0 = none")
    rated_torque = Parameter(50.0, unit="N.m", min=0.0,
                             description="ideal mode: the wheel torque a drive of this robot can "
                                         "give (commands beyond twice it are warned about)")

    torque_command = Input(size=2, unit="N.m", description="(tau_R, tau_L) requested")
    wheel_speed = Input(size=2, unit="rad/s", description="load (wheel) speed, for back-EMF")
    torque = Output(size=2, unit="N.m", depends_on=("torque_command",), description="applied")
    measured_speed = Output(size=2, unit="rad/s", description="encoder speed, end of step")
    angle = Output(size=2, unit="rad", description="encoder angle, end of step")

    def limits(self) -> dict[str, tuple[float, float]]:
        """Ideal mode: the applied torques within +-torque_max (when there is one)."""
        limit = float(self.torque_max)
        return {"torque": (-limit, limit)} if self.mode == "ideal" and limit > 0 else {}

    def initialize(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"unknown mode '{self.mode}'; use {' or '.join(map(repr, MODES))}")
        self._limit = self._kt() * self.I_max if self.mode == "dc" else (
            self.torque_max or self.rated_torque)
        self._warned = False
        self.evaluate(self.start_time)

    def _kt(self) -> float:
        return self.efficiency * self.gear * self.K_t

    def kernel(self, h: float) -> Kernel:
        """The motor driver's definition, for steps of h [s] (dc: the armature discretised
        here)."""
        dc = self.mode == "dc"
        coef = armature_zoh(self.R, self.L, self.K_e, self.gear, h) if dc else (0.0, 0.0, 0.0)
        limit = self._limit
        return Kernel(
            params=MotorParams(float(MODES[self.mode]), float(self.torque_max), self._kt(),
                               self.L * self.bandwidth, self.R * self.bandwidth,
                               float(self.I_max), float(self.V_max), *coef),
            state=MotorState(0.0, 0.0, 0.0, 0.0, 2.0 * limit if limit > 0.0 else math.inf,
                             math.nan, 0.0, 0.0),
            evaluate=motor_evaluate, step=motor_step, sync=self._sync)

    def _sync(self, x: MotorState) -> None:
        """Once per run: the warning about the first command beyond twice the drive's limit."""
        if math.isnan(x.t_implausible) or self._warned:
            return
        self._warned = True
        logging.getLogger("twmr.run").warning(
            "component '%s': torque command (%.4g, %.4g) N.m at t = %.6g s is far beyond the "
            "drive's limit of %.4g N.m%s. Fix: check the controller's gains and the start "
            "(this warning is given once per run).", self.name, x.c_R, x.c_L, x.t_implausible,
            self._limit, "; it is applied as is (mode ideal)" if self.mode == "ideal" else "")


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
MotorDriver.c_twin = CTwin(TWINS / "motor.c", work=lambda comp: 9,
                           choices={"mode": Choice("MODE_DC", {"ideal": 0, "dc": 1})})
