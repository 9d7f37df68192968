"""Reference trajectories of the target point T: position, velocity and acceleration at time t.

Shapes: `paper1` (x_T = -t, y_T = sin(0.5 t) + 0.5 t + 1, the paper's trajectory 1), `circle`
(centre, radius R, rate omega, phase), `lemniscate` (Gerono: x = A sin(w t), y = A/2 sin(2 w t),
around the centre) and `waypoints` (a C2 cubic spline through (time, x, y) points, clamped with
zero end velocity). Every derivative is analytic.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from twmr.components.ctwins import C as TWINS
from twmr.core import STRING, Component, Output, Parameter
from twmr.core.ctwin import Choice, CTwin
from twmr.core.kernel import Kernel, kernel_function

#: kernel codes of the analytic shapes, name -> code (`waypoints` runs in Python only)
PAPER1, CIRCLE, LEMNISCATE = 0, 1, 2
SHAPES = {"paper1": PAPER1, "circle": CIRCLE, "lemniscate": LEMNISCATE}
#: every shape name the block takes
NAMES = (*SHAPES, "waypoints")


class TrajectoryParams(NamedTuple):
    """The parameter table of an analytic shape."""

    code: float  #: SHAPES
    radius: float  #: circle radius / lemniscate size A [m]
    omega: float  #: [rad/s]
    phase: float  #: circle phase at t = 0 [rad]
    cx: float  #: centre [m]
    cy: float


Sample = tuple[tuple[float, float], tuple[float, float], tuple[float, float]]


@kernel_function
def sample_kernel(t: float, p: TrajectoryParams) -> Sample:
    """(position, velocity, acceleration) of an analytic shape at t [s]."""
    if p.code == PAPER1:
        return ((-t, math.sin(0.5 * t) + 0.5 * t + 1.0), (-1.0, 0.5 * math.cos(0.5 * t) + 0.5),
                (0.0, -0.25 * math.sin(0.5 * t)))
    cx, cy = p.cx, p.cy
    w = p.omega
    if p.code == CIRCLE:
        R, a = p.radius, w * t + p.phase
        c, s = math.cos(a), math.sin(a)
        return ((cx + R * c, cy + R * s), (-R * w * s, R * w * c),
                (-R * w * w * c, -R * w * w * s))
    A = p.radius
    s1, c1 = math.sin(w * t), math.cos(w * t)
    s2, c2 = math.sin(2 * w * t), math.cos(2 * w * t)
    return ((cx + A * s1, cy + A / 2 * s2), (A * w * c1, A * w * c2),
            (-A * w * w * s1, -2 * A * w * w * s2))


@kernel_function
def trajectory_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: TrajectoryParams
                    ) -> tuple[tuple, tuple]:
    """`Trajectory.do_step` of an analytic shape: the outputs at t + h [s]."""
    return x, sample_kernel(t + h, p)


class Trajectory(Component):
    """Reference point T(t) with velocity and acceleration; see the module for the shapes."""

    kind = "trajectory"
    shape = Parameter("paper1", type=STRING, description=" | ".join(NAMES))
    radius = Parameter(5.0, unit="m", min=0.0, description="circle radius / lemniscate size A")
    omega = Parameter(0.1 * math.pi, unit="rad/s", description="angular rate")
    phase = Parameter(0.0, unit="rad", description="circle phase at t = 0")
    center = Parameter((0.0, 0.0), size=2, unit="m", description="circle / lemniscate centre")
    waypoints = Parameter((0.0, 0.0, 1.0, 1.0), size=0, unit="m",
                          description="x1, y1, x2, y2, ... (waypoints shape)")
    times = Parameter((0.0, 10.0), size=0, unit="s", description="time of each waypoint")

    position = Output(size=2, unit="m", description="(x_T, y_T)")
    velocity = Output(size=2, unit="m/s", description="(x_T', y_T')")
    acceleration = Output(size=2, unit="m/s2", description="(x_T'', y_T'')")

    def initialize(self) -> None:
        if self.shape not in NAMES:
            raise ValueError(f"unknown shape '{self.shape}'; use one of {', '.join(NAMES)}")
        if self.shape == "waypoints":
            pts = np.reshape(np.asarray(self.waypoints, dtype=float), (-1, 2))
            times = np.asarray(self.times, dtype=float)
            if len(times) != len(pts) or len(pts) < 2 or np.any(np.diff(times) <= 0):
                raise ValueError(f"waypoints need one increasing time per point: {len(pts)} "
                                 f"points, {len(times)} times")
            from scipy.interpolate import CubicSpline

            self._spline = CubicSpline(times, pts, bc_type="clamped")
        self.position, self.velocity, self.acceleration = self.sample(self.start_time)

    def params(self) -> TrajectoryParams:
        """The table of an analytic shape."""
        cx, cy = self.center
        return TrajectoryParams(float(SHAPES[self.shape]), float(self.radius), float(self.omega),
                                float(self.phase), float(cx), float(cy))

    def sample(self, t: float) -> Sample:
        """(position, velocity, acceleration) at time t [s]."""
        if self.shape != "waypoints":
            return sample_kernel(t, self.params())
        sp = self._spline
        tt = min(max(t, float(sp.x[0])), float(sp.x[-1]))
        p, v, a_ = sp(tt), sp(tt, 1), sp(tt, 2)
        if tt != t:  # hold the end point
            v, a_ = v * 0.0, a_ * 0.0
        return (float(p[0]), float(p[1])), (float(v[0]), float(v[1])), (float(a_[0]), float(a_[1]))

    def kernel(self, h: float) -> Kernel | None:
        """The definition of the analytic shapes (`waypoints`, a scipy spline: Python only)."""
        if self.shape == "waypoints":
            return None
        return Kernel(params=self.params(), step=trajectory_step)

    def do_step(self, t: float, h: float) -> None:
        if self.shape != "waypoints":
            self.kernel_do_step(t, h)
            return
        self.position, self.velocity, self.acceleration = self.sample(t + h)


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
#: the analytic shapes the C twin draws (`waypoints` is a scipy spline: Python only)
C_SHAPES = {"paper1": PAPER1, "circle": CIRCLE, "lemniscate": LEMNISCATE}
Trajectory.c_twin = CTwin(
    TWINS / "trajectory.c", tunable=frozenset({"radius", "omega", "phase", "center"}),
    choices={"shape": Choice("SHAPE", {k: int(v) for k, v in C_SHAPES.items()})},
    defines={f"SHAPE_{k.upper()}": int(v) for k, v in C_SHAPES.items()},
    hidden=frozenset({"waypoints", "times"}))
