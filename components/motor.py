"""Motor driver of each wheel: torque command in; applied torque, measured speed and angle out.

`mode: ideal` applies the command exactly (the paper's assumption), limited to `torque_max` per
wheel when that is set. `mode: dc` models a geared DC
motor per wheel with a PI current loop:

    L di/dt = V - R i - K_e N omega_wheel        (armature; N = gear ratio)
    tau_wheel = eta_g N K_t i                    (applied torque)
    i_ref = clamp(tau_cmd / (eta_g N K_t), +-I_max)
    V = clamp(K_p (i_ref - i) + K_i z, +-V_max), z' = i_ref - i (integration held while saturated)

The armature is an LTI model (python-control `ss`) discretised exactly for a held voltage and speed
with `control.c2d(..., 'zoh')` at the component's step (again whenever the step changes); the PI
law runs at that step. Default PI gains place the current loop at `bandwidth` [rad/s]:
K_p = L bandwidth, K_i = R bandwidth. Defaults: a 24 V, ~250 W geared motor (R 0.3 Ohm, L 0.3 mH,
K_t = K_e = 0.06, N = 20, I_max 40 A: 48 N.m at the wheel).

Measured speed and angle are sampled at the end of each step from the wheel speed input held over
it (an encoder), so they do not depend directly on inputs.

A command beyond twice the drive's limit (I_max eta_g N K_t in `dc` mode; in `ideal` mode
`torque_max`, or `rated_torque` when no limit is set and the command is applied anyway) is
implausible for the robot: the run's output warns about the first one, once.
"""
from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from twmr.components._model import njit
from twmr.core import STRING, Component, Input, Output, Parameter
from twmr.master.compiled import Kernel


@njit(cache=True, error_model="numpy")
def motor_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: tuple) -> tuple[tuple, tuple]:
    """Kernel of `MotorDriver.evaluate`. x = (i_R, i_L [A], z_R, z_L [A.s], implausible
    [N.m], time of the first implausible command [s] (nan: none), that command (2) [N.m]);
    p = (0 ideal | 1 dc, torque_max, eta_g N K_t, K_p, K_i, I_max, V_max, a, b_V, b_omega);
    y = (torque, measured_speed, angle)."""
    c = u[0]
    if abs(c[0]) > x[4] or abs(c[1]) > x[4]:
        x = (x[0], x[1], x[2], x[3], math.inf, t, c[0], c[1])
    if p[0] == 0.0:
        m = p[1]
        torque = (min(m, max(-m, c[0])), min(m, max(-m, c[1]))) if m > 0.0 else c
    else:
        kt = p[2]
        torque = (kt * x[0], kt * x[1])
    return x, (torque, y[1], y[2])


@njit(cache=True, error_model="numpy")
def motor_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
               ) -> tuple[tuple, tuple]:
    """Kernel of `MotorDriver.do_step` (the zoh coefficients a, b_V, b_omega of the step h are
    parameters)."""
    c, w = u[0], u[1]
    a0, a1 = y[2]
    angle = (a0 + w[0] * h, a1 + w[1] * h)
    if p[0] == 0.0:
        return x, (y[0], w, angle)
    kt, kp, ki, imax, vmax = p[2], p[3], p[4], p[5], p[6]
    i0, i1, z0, z1 = x[0], x[1], x[2], x[3]
    i_ref = min(imax, max(-imax, c[0] / kt))
    err = i_ref - i0
    v_raw = kp * err + ki * z0
    v = min(vmax, max(-vmax, v_raw))
    if v == v_raw:
        z0 += err * h
    i0 = p[7] * i0 + p[8] * v + p[9] * w[0]
    i_ref = min(imax, max(-imax, c[1] / kt))
    err = i_ref - i1
    v_raw = kp * err + ki * z1
    v = min(vmax, max(-vmax, v_raw))
    if v == v_raw:
        z1 += err * h
    i1 = p[7] * i1 + p[8] * v + p[9] * w[1]
    return (i0, i1, z0, z1, x[4], x[5], x[6], x[7]), ((kt * i0, kt * i1), w, angle)


class MotorDriver(Component):
    """Two wheel drives: ideal torque source or geared DC motor with a PI current loop."""

    kind = "motor_driver"
    mode = Parameter("ideal", type=STRING, description="ideal | dc")
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

    def initialize(self) -> None:
        if self.mode not in ("ideal", "dc"):
            raise ValueError(f"unknown mode '{self.mode}'; use 'ideal' or 'dc'")
        self._i = [0.0, 0.0]
        self._z = [0.0, 0.0]
        self._h = 0.0
        limit = self._kt() * self.I_max if self.mode == "dc" else (
            self.torque_max or self.rated_torque)
        self._limit = limit
        self._implausible = 2.0 * limit if limit > 0.0 else float("inf")
        self.evaluate(self.start_time)

    def armature(self) -> Any:
        """di/dt = (-R i + V - K_e N omega) / L; inputs (V, omega_wheel), output i (a
        python-control StateSpace)."""
        import control

        return control.ss([[-self.R / self.L]], [[1.0 / self.L, -self.K_e * self.gear / self.L]],
                          [[1.0]], [[0.0, 0.0]])

    def _discretise(self, h: float) -> None:
        import control

        d = control.c2d(self.armature(), h, method="zoh")
        self._a = float(d.A[0, 0])
        self._bv, self._bw = float(d.B[0, 0]), float(d.B[0, 1])
        self._h = h

    def _kt(self) -> float:
        return self.efficiency * self.gear * self.K_t

    def kernel(self, h: float) -> Kernel:
        """The compiled form, for steps of h [s] (dc: the armature discretised here)."""
        dc = self.mode == "dc"
        if dc:
            self._discretise(h)
        coef = (self._a, self._bv, self._bw) if dc else (0.0, 0.0, 0.0)
        return Kernel(params=(1.0 if dc else 0.0, float(self.torque_max), self._kt(),
                              self.L * self.bandwidth, self.R * self.bandwidth,
                              float(self.I_max), float(self.V_max), *coef),
                      state=(*self._i, *self._z, self._implausible, math.nan, 0.0, 0.0),
                      evaluate=motor_evaluate, step=motor_step, sync=self._sync)

    def _sync(self, x: tuple) -> None:
        """After compiled steps: the warning about an implausible command, once."""
        if not math.isnan(x[5]) and self._implausible != float("inf"):
            self._warn(x[5], (x[6], x[7]))

    def _warn(self, t: float, c: tuple[float, float]) -> None:
        """Once per run: a command `c` [N.m] beyond twice the drive's limit."""
        logging.getLogger("twmr.run").warning(
            "component '%s': torque command (%.4g, %.4g) N.m at t = %.6g s is far beyond the "
            "drive's limit of %.4g N.m%s. Fix: check the controller's gains and the start "
            "(this warning is given once per run).", self.name, c[0], c[1], t, self._limit,
            "; it is applied as is (mode ideal)" if self.mode == "ideal" else "")
        self._implausible = float("inf")

    def evaluate(self, t: float) -> None:
        c = self.torque_command
        if abs(c[0]) > self._implausible or abs(c[1]) > self._implausible:
            self._warn(t, c)
        if self.mode == "ideal":
            m = self.torque_max
            self.torque = (min(m, max(-m, c[0])), min(m, max(-m, c[1]))) if m > 0.0 else c
        else:
            kt = self._kt()
            self.torque = (kt * self._i[0], kt * self._i[1])

    def do_step(self, t: float, h: float) -> None:
        w = self.wheel_speed
        a0, a1 = self.angle
        self.angle = (a0 + w[0] * h, a1 + w[1] * h)
        self.measured_speed = w
        if self.mode == "ideal":
            return
        if h != self._h:
            self._discretise(h)
        kt, kp, ki = self._kt(), self.L * self.bandwidth, self.R * self.bandwidth
        for j in (0, 1):
            i_ref = float(np.clip(self.torque_command[j] / kt, -self.I_max, self.I_max))
            err = i_ref - self._i[j]
            v_raw = kp * err + ki * self._z[j]
            v = min(self.V_max, max(-self.V_max, v_raw))
            if v == v_raw:
                self._z[j] += err * h  # anti-windup: hold the integral while saturated
            self._i[j] = self._a * self._i[j] + self._bv * v + self._bw * w[j]
        self.torque = (kt * self._i[0], kt * self._i[1])
