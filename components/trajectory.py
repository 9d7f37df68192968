"""Reference trajectories of the target point T: position, velocity and acceleration at time t.

Shapes: `paper1` (x_T = -t, y_T = sin(0.5 t) + 0.5 t + 1, the paper's trajectory 1), `circle`
(centre, radius R, rate omega, phase), `lemniscate` (Gerono: x = A sin(w t), y = A/2 sin(2 w t),
around the centre) and `waypoints` (a C2 cubic spline through (time, x, y) points, clamped with
zero end velocity). Every derivative is analytic.
"""
from __future__ import annotations

import math

import numpy as np

from twmr.components._model import njit
from twmr.core import STRING, Component, Output, Parameter
from twmr.master.compiled import Kernel

SHAPES = ("paper1", "circle", "lemniscate", "waypoints")
#: kernel codes of the analytic shapes (`waypoints` runs in Python only)
PAPER1, CIRCLE, LEMNISCATE = 0.0, 1.0, 2.0


@njit(cache=True, error_model="numpy")
def sample_kernel(t: float, p: tuple) -> tuple:
    """(position, velocity, acceleration) of an analytic shape at t [s]; p = (code, radius,
    omega, phase, cx, cy), as `Trajectory.sample`."""
    code = p[0]
    if code == PAPER1:
        return ((-t, math.sin(0.5 * t) + 0.5 * t + 1.0), (-1.0, 0.5 * math.cos(0.5 * t) + 0.5),
                (0.0, -0.25 * math.sin(0.5 * t)))
    cx, cy = p[4], p[5]
    w = p[2]
    if code == CIRCLE:
        R, a = p[1], w * t + p[3]
        c, s = math.cos(a), math.sin(a)
        return ((cx + R * c, cy + R * s), (-R * w * s, R * w * c),
                (-R * w * w * c, -R * w * w * s))
    A = p[1]
    s1, c1 = math.sin(w * t), math.cos(w * t)
    s2, c2 = math.sin(2 * w * t), math.cos(2 * w * t)
    return ((cx + A * s1, cy + A / 2 * s2), (A * w * c1, A * w * c2),
            (-A * w * w * s1, -2 * A * w * w * s2))


@njit(cache=True, error_model="numpy")
def trajectory_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: tuple
                    ) -> tuple[tuple, tuple]:
    """Kernel step: the outputs at t + h [s]."""
    return x, sample_kernel(t + h, p)


class Trajectory(Component):
    """Reference point T(t) with velocity and acceleration; see the module for the shapes."""

    kind = "trajectory"
    shape = Parameter("paper1", type=STRING, description="paper1 | circle | lemniscate | waypoints")
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
        if self.shape not in SHAPES:
            raise ValueError(f"unknown shape '{self.shape}'; use one of {', '.join(SHAPES)}")
        if self.shape == "waypoints":
            pts = np.reshape(np.asarray(self.waypoints, dtype=float), (-1, 2))
            times = np.asarray(self.times, dtype=float)
            if len(times) != len(pts) or len(pts) < 2 or np.any(np.diff(times) <= 0):
                raise ValueError(f"waypoints need one increasing time per point: {len(pts)} "
                                 f"points, {len(times)} times")
            from scipy.interpolate import CubicSpline

            self._spline = CubicSpline(times, pts, bc_type="clamped")
        self._set(self.start_time)

    def sample(self, t: float) -> tuple[tuple[float, float], tuple[float, float],
                                        tuple[float, float]]:
        """(position, velocity, acceleration) at time t [s]."""
        if self.shape == "paper1":
            return ((-t, math.sin(0.5 * t) + 0.5 * t + 1.0), (-1.0, 0.5 * math.cos(0.5 * t) + 0.5),
                    (0.0, -0.25 * math.sin(0.5 * t)))
        cx, cy = self.center
        w = self.omega
        if self.shape == "circle":
            R, a = self.radius, w * t + self.phase
            c, s = math.cos(a), math.sin(a)
            return ((cx + R * c, cy + R * s), (-R * w * s, R * w * c),
                    (-R * w * w * c, -R * w * w * s))
        if self.shape == "lemniscate":
            A = self.radius
            s1, c1 = math.sin(w * t), math.cos(w * t)
            s2, c2 = math.sin(2 * w * t), math.cos(2 * w * t)
            return ((cx + A * s1, cy + A / 2 * s2), (A * w * c1, A * w * c2),
                    (-A * w * w * s1, -2 * A * w * w * s2))
        sp = self._spline
        tt = min(max(t, float(sp.x[0])), float(sp.x[-1]))
        p, v, a_ = sp(tt), sp(tt, 1), sp(tt, 2)
        if tt != t:  # hold the end point
            v, a_ = v * 0.0, a_ * 0.0
        return (float(p[0]), float(p[1])), (float(v[0]), float(v[1])), (float(a_[0]), float(a_[1]))

    def kernel(self, h: float) -> Kernel | None:
        """The compiled form (analytic shapes only; `waypoints` runs in Python)."""
        code = {"paper1": PAPER1, "circle": CIRCLE, "lemniscate": LEMNISCATE}.get(self.shape)
        if code is None:
            return None
        cx, cy = self.center
        return Kernel(params=(code, float(self.radius), float(self.omega), float(self.phase),
                              float(cx), float(cy)), step=trajectory_step)

    def _set(self, t: float) -> None:
        self.position, self.velocity, self.acceleration = self.sample(t)

    def do_step(self, t: float, h: float) -> None:
        self._set(t + h)
