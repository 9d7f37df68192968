"""Wheel slip and external disturbance generator: (mu_R', mu_L', delta'), their derivatives, tau_d.

Profiles:
- `paper`: [mu_R' mu_L' delta'] = [1 + cos t, 1 + sin t, cos t] m/s, tau_d = [2 sin 3t, 2 cos 3t]
  N.m (Sec. IV-A), with the exact derivatives; `phase` [s] shifts it (t + phase);
- `none`: all zero;
- `constant`: `slip_value`, `disturbance_value`;
- `step`: zero before `step_time`, the constant values from then on (derivative 0: an ideal step);
- `mud`: `slip_value` while the robot's M is within `mud_radius` of `mud_center`, else 0 (an abrupt
  patch: derivative 0), the disturbance `disturbance_value` likewise;
- `random`: white noise of unit variance per sample (numpy Generator, `seed`) through a first-order
  low-pass of `bandwidth` [Hz], scaled by `slip_value` / `disturbance_value` as standard
  deviations; its derivative is the filter's state derivative. Deterministic for a seed and step.
`slip_gain` and `disturbance_gain` scale the two parts (0 switches either off).

Output `model` hands the plant the profile itself (a descriptor: `_model.DESCRIPTOR`), so the
plant evaluates it at its own integration stages instead of holding the values over each step
(`random` is a sampled signal: its descriptor says "held").
"""
from __future__ import annotations

import math

import numpy as np

from twmr.components._model import CONSTANT, DESCRIPTOR, HELD, MUD, NO_SLIP, PAPER, STEP, njit
from twmr.core import STRING, Component, Input, Output, Parameter
from twmr.master.compiled import Kernel

PROFILES = ("paper", "none", "constant", "step", "mud", "random")


@njit(cache=True, error_model="numpy")
def slip_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: tuple) -> tuple[tuple, tuple]:
    """Kernel of `SlipDisturbance.evaluate` (every profile but `random`); p = (code, phase,
    slip_value (3), disturbance_value (2), step_time, mud_center (2), mud_radius, slip_gain,
    disturbance_gain); y = (slip_rate, slip_accel, disturbance, model)."""
    code = p[0]
    if code == PAPER:
        tp = t + p[1]
        rate = (1.0 + math.cos(tp), 1.0 + math.sin(tp), math.cos(tp))
        accel = (-math.sin(tp), math.cos(tp), -math.sin(tp))
        dist = (2.0 * math.sin(3.0 * tp), 2.0 * math.cos(3.0 * tp))
    elif code == NO_SLIP:
        rate, accel, dist = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0)
    else:
        pose = u[0]
        on = code == CONSTANT or (code == STEP and t >= p[7]) or (
            code == MUD and math.hypot(pose[0] - p[8], pose[1] - p[9]) <= p[10])
        rate = (p[2], p[3], p[4]) if on else (0.0, 0.0, 0.0)
        accel = (0.0, 0.0, 0.0)
        dist = (p[5], p[6]) if on else (0.0, 0.0)
    g, gd = p[11], p[12]
    return x, ((g * rate[0], g * rate[1], g * rate[2]), (g * accel[0], g * accel[1], g * accel[2]),
               (gd * dist[0], gd * dist[1]), y[3])


class SlipDisturbance(Component):
    """Slip velocities, slip accelerations and disturbance torques; see the module for profiles."""

    kind = "slip_disturbance"
    profile = Parameter("paper", type=STRING, description=" | ".join(PROFILES))
    slip_value = Parameter((0.5, 0.5, 0.2), size=3, unit="m/s",
                           description="slip (mu_R', mu_L', delta') of constant/step/mud/random")
    disturbance_value = Parameter((1.0, 1.0), size=2, unit="N.m", description="tau_d of those")
    step_time = Parameter(1.0, unit="s")
    phase = Parameter(0.0, unit="s", description="time shift of the paper profile")
    mud_center = Parameter((0.0, 0.0), size=2, unit="m")
    mud_radius = Parameter(1.0, unit="m", min=0.0)
    bandwidth = Parameter(1.0, unit="Hz", min=1e-6)
    seed = Parameter(0, type="Integer")
    slip_gain = Parameter(1.0)
    disturbance_gain = Parameter(1.0)

    pose = Input(size=3, unit=("m", "m", "rad"), description="robot pose (mud profile)")
    slip_rate = Output(size=3, unit="m/s", depends_on=("pose",))
    slip_accel = Output(size=3, unit="m/s2", depends_on=("pose",))
    disturbance = Output(size=2, unit="N.m", depends_on=("pose",))
    model = Output(size=DESCRIPTOR, description="the profile for the plant to evaluate itself "
                                                "(wire it to plant.slip_model)")

    def initialize(self) -> None:
        if self.profile not in PROFILES:
            raise ValueError(f"unknown profile '{self.profile}'; use one of {', '.join(PROFILES)}")
        self._rng = np.random.default_rng(self.seed)
        self._noise = [0.0] * 5
        self._dnoise = [0.0] * 5
        code = {"paper": PAPER, "none": NO_SLIP, "constant": CONSTANT, "step": STEP,
                "mud": MUD}.get(self.profile, HELD)
        self.model = (float(code), float(self.slip_gain), float(self.disturbance_gain),
                      *map(float, self.slip_value), *map(float, self.disturbance_value),
                      float(self.step_time), *map(float, self.mud_center), float(self.mud_radius),
                      float(self.phase))
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel | None:
        """The compiled form; none for `random` (a numpy Generator: runs in Python)."""
        if self.profile == "random":
            return None
        return Kernel(params=(self.model[0], float(self.phase), *map(float, self.slip_value),
                              *map(float, self.disturbance_value), float(self.step_time),
                              *map(float, self.mud_center), float(self.mud_radius),
                              float(self.slip_gain), float(self.disturbance_gain)),
                      evaluate=slip_evaluate)

    def evaluate(self, t: float) -> None:
        zero3 = (0.0, 0.0, 0.0)
        p = self.profile
        if p == "paper":
            tp = t + self.phase
            rate = (1.0 + math.cos(tp), 1.0 + math.sin(tp), math.cos(tp))
            accel = (-math.sin(tp), math.cos(tp), -math.sin(tp))
            dist = (2.0 * math.sin(3.0 * tp), 2.0 * math.cos(3.0 * tp))
        elif p == "none":
            rate, accel, dist = zero3, zero3, (0.0, 0.0)
        elif p in ("constant", "step", "mud"):
            on = p == "constant" or (p == "step" and t >= self.step_time) or (
                p == "mud" and math.hypot(self.pose[0] - self.mud_center[0],
                                          self.pose[1] - self.mud_center[1]) <= self.mud_radius)
            rate = self.slip_value if on else zero3
            accel = zero3
            dist = self.disturbance_value if on else (0.0, 0.0)
        else:  # random
            scale = tuple(self.slip_value) + tuple(self.disturbance_value)
            rate = tuple(scale[i] * self._noise[i] for i in range(3))
            accel = tuple(scale[i] * self._dnoise[i] for i in range(3))
            dist = (scale[3] * self._noise[3], scale[4] * self._noise[4])
        g, gd = self.slip_gain, self.disturbance_gain
        self.slip_rate = (g * rate[0], g * rate[1], g * rate[2])
        self.slip_accel = (g * accel[0], g * accel[1], g * accel[2])
        self.disturbance = (gd * dist[0], gd * dist[1])

    def do_step(self, t: float, h: float) -> None:
        if self.profile != "random":
            return
        wc = 2.0 * math.pi * self.bandwidth  # x' = wc (w - x), w white with unit variance
        a = math.exp(-wc * h)
        gain = math.sqrt(1.0 - a * a)  # keeps the stationary variance at 1
        white = self._rng.standard_normal(5)
        for i in range(5):
            new = a * self._noise[i] + gain * white[i]
            self._dnoise[i] = (new - self._noise[i]) / h
            self._noise[i] = new
