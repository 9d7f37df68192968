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

Output `model` hands the plant the profile itself (a `_model.SlipProfile`, also this block's
parameter table), so the plant evaluates it at its own integration stages instead of holding the
values over each step (`random` is a sampled signal: its code says "held"). Every profile but
`random` is defined once, by `_model.slip_at`, for this block and for the plant.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from twmr.components._model import DESCRIPTOR, HELD, PROFILES, SlipProfile, slip_at
from twmr.components.ctwins import PROFILES as C_PROFILES
from twmr.components.ctwins import SLIP_DEFINES, SLIP_PROFILE
from twmr.components.ctwins import C as TWINS
from twmr.core import STRING, Component, Input, Output, Parameter
from twmr.core.ctwin import Choice, CTwin
from twmr.core.kernel import Kernel, kernel_function

#: every profile name the block takes
NAMES = (*PROFILES, "random")


@kernel_function
def slip_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: SlipProfile) -> tuple[tuple, tuple]:
    """`SlipDisturbance.evaluate` (every profile but `random`): u = (pose,); y = (slip_rate,
    slip_accel, disturbance, model)."""
    pose = u[0]
    # the profile it hands the plant (`model`, the values of p): one evaluation for both
    muR, muL, dl, muR2, muL2, dl2, tdR, tdL = slip_at(y[3], t, pose[0], pose[1])
    return x, ((muR, muL, dl), (muR2, muL2, dl2), (tdR, tdL), y[3])


@kernel_function
def slip_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: SlipProfile
              ) -> tuple[tuple, tuple]:
    """`SlipDisturbance.do_step`: no state; the outputs at t + h with the pose held, as its C
    FMU reports them after fmi2DoStep (what a Jacobi master passes on)."""
    return slip_evaluate(t + h, x, y, u, p)


@kernel_function
def slip_advance(t: float, h: float, x: tuple, y: tuple, u: tuple, p: SlipProfile
                 ) -> tuple[tuple, tuple]:
    """`slip_step` without its outputs at t + h (all but `model`, which it keeps, are the
    next point's `slip_evaluate`)."""
    return x, y


class SlipDisturbance(Component):
    """Slip velocities, slip accelerations and disturbance torques; see the module for profiles."""

    kind = "slip_disturbance"
    profile = Parameter("paper", type=STRING, description=" | ".join(NAMES))
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

    #: the `random` profile's filter: its state and derivative (mu_R', mu_L', delta', tau_d)
    state_attributes = ("_noise", "_dnoise")

    def initialize(self) -> None:
        if self.profile not in NAMES:
            raise ValueError(f"unknown profile '{self.profile}'; use one of {', '.join(NAMES)}")
        #: the `random` profile's noise generator (made for that profile alone)
        self._rng = np.random.default_rng(self.seed) if self.profile == "random" else None
        self._noise: tuple[float, ...] = (0.0,) * 5
        self._dnoise: tuple[float, ...] = (0.0,) * 5
        self.model = tuple(self.params())
        self.evaluate(self.start_time)

    def params(self) -> SlipProfile:
        """The profile as a table (code HELD for `random`)."""
        return SlipProfile(
            float(PROFILES.get(self.profile, HELD)), float(self.slip_gain),
            float(self.disturbance_gain), *map(float, self.slip_value),
            *map(float, self.disturbance_value), float(self.step_time),
            *map(float, self.mud_center), float(self.mud_radius), float(self.phase))

    def kernel(self, h: float) -> Kernel | None:
        """The definition of every profile but `random` (a numpy Generator: Python only)."""
        if self.profile == "random":
            return None
        return Kernel(params=self.params(), evaluate=slip_evaluate, step=slip_step,
                      advance=slip_advance)

    def evaluate(self, t: float) -> None:
        if self.profile != "random":
            self.kernel_evaluate(t)
            return
        scale = tuple(self.slip_value) + tuple(self.disturbance_value)
        g, gd = self.slip_gain, self.disturbance_gain
        self.slip_rate = tuple(g * (scale[i] * self._noise[i]) for i in range(3))
        self.slip_accel = tuple(g * (scale[i] * self._dnoise[i]) for i in range(3))
        self.disturbance = (gd * (scale[3] * self._noise[3]), gd * (scale[4] * self._noise[4]))

    def do_step(self, t: float, h: float) -> None:
        if self.profile != "random":
            self.kernel_do_step(t, h)
            return
        wc = 2.0 * math.pi * self.bandwidth  # x' = wc (w - x), w white with unit variance
        a = math.exp(-wc * h)
        gain = math.sqrt(1.0 - a * a)  # keeps the stationary variance at 1
        assert self._rng is not None  # made by initialize for the random profile
        white = self._rng.standard_normal(5)
        new = tuple(a * self._noise[i] + gain * float(white[i]) for i in range(5))
        self._dnoise = tuple((new[i] - self._noise[i]) / h for i in range(5))
        self._noise = new

    def get_state(self) -> Any:
        """The ports and the filter's state (`state_attributes`), then the noise generator's:
        ``("_rng", (state, inc, has_uint32, uinteger))`` of its PCG64 bit generator, plain
        integers, so a restored `random` run draws the same numbers again."""
        saved = super().get_state()
        rng = self.__dict__.get("_rng")
        if rng is None:
            return saved
        s = rng.bit_generator.state
        return (*saved, ("_rng", (int(s["state"]["state"]), int(s["state"]["inc"]),
                                  int(s["has_uint32"]), int(s["uinteger"]))))

    def set_state(self, state: Any) -> None:
        rng = None
        if isinstance(state, tuple) and state and isinstance(state[-1], tuple) and \
                len(state[-1]) == 2 and state[-1][0] == "_rng":
            state, (_, rng) = state[:-1], state[-1]
        super().set_state(state)
        if rng is not None:
            value, inc, has_uint32, uinteger = rng
            bits = np.random.PCG64()
            bits.state = {"bit_generator": "PCG64", "state": {"state": value, "inc": inc},
                          "has_uint32": has_uint32, "uinteger": uinteger}
            self._rng = np.random.Generator(bits)


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
SlipDisturbance.c_twin = CTwin(TWINS / "slip.c", headers=(SLIP_PROFILE,), defines=SLIP_DEFINES,
                               choices={"profile": Choice("PROFILE", C_PROFILES)},
                               hidden=frozenset({"bandwidth", "seed"}))
