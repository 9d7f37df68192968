"""Trajectory and slip generators: values, analytic derivatives against finite differences."""
from __future__ import annotations

import math

import numpy as np
import pytest

from twmr.components.slip import SlipDisturbance
from twmr.components.trajectory import Trajectory
from twmr.testing import Harness


def make(cls, start: float = 0.0, step: float = 1e-3, **kw) -> Harness:
    """An initialized harness around `cls` with parameters `kw`, from `start` to 20 s at
    communication step `step`."""
    return Harness(cls, name="c", parameters=kw, start=start, stop=20.0, step=step).initialize()


def sample(t: float, **kw) -> tuple[tuple[float, float], ...]:
    """(position, velocity, acceleration) of a trajectory with parameters `kw` at time t: its
    outputs after initialize() with the experiment starting at t."""
    tr = make(Trajectory, start=t, **kw)
    return tr["position"], tr["velocity"], tr["acceleration"]


@pytest.mark.parametrize("kw", [
    {"shape": "paper1"}, {"shape": "circle", "radius": 5.0, "omega": 0.3, "phase": 0.2},
    {"shape": "lemniscate", "radius": 2.0, "omega": 0.5},
    {"shape": "waypoints", "waypoints": [0, 0, 1, 2, 3, 1, 4, 4], "times": [0, 2, 5, 9]},
])
def test_trajectory_derivatives_match_finite_differences(kw) -> None:
    h = 1e-5
    for t in (0.7, 3.3, 6.1):
        p0, v0, _a0 = sample(t - h, **kw)
        p1, v1, _ = sample(t + h, **kw)
        _, v, a = sample(t, **kw)
        np.testing.assert_allclose((np.array(p1) - p0) / (2 * h), v, atol=1e-6)
        np.testing.assert_allclose((np.array(v1) - v0) / (2 * h), a, atol=1e-5)


def test_paper_trajectory_and_circle_values() -> None:
    p, _, _ = sample(2.0, shape="paper1")
    assert p == pytest.approx((-2.0, math.sin(1.0) + 2.0))
    circle = {"shape": "circle", "radius": 5.0, "omega": 0.1 * math.pi}
    for t in np.linspace(0, 20, 7):
        assert math.hypot(*sample(float(t), **circle)[0]) == pytest.approx(5.0)


def test_paper_slip_profile_and_its_derivatives() -> None:
    h = 1e-6
    for t in (0.3, 2.0, 5.5):
        s = make(SlipDisturbance, start=t, step=h, profile="paper")
        s.evaluate()  # at t
        rate, accel, dist = s["slip_rate"], s["slip_accel"], s["disturbance"]
        assert rate == pytest.approx((1 + math.cos(t), 1 + math.sin(t), math.cos(t)))
        assert dist == pytest.approx((2 * math.sin(3 * t), 2 * math.cos(3 * t)))
        s.step()
        s.evaluate()  # at t + h
        np.testing.assert_allclose((np.array(s["slip_rate"]) - rate) / h, accel, atol=1e-5)


def test_mud_patch_switches_slip_with_position() -> None:
    s = make(SlipDisturbance, profile="mud", mud_center=(2.0, 0.0), mud_radius=1.0,
             slip_value=(0.4, 0.3, 0.1))
    s.set(pose=(0.0, 0.0, 0.0))
    s.evaluate()
    assert s["slip_rate"] == (0.0, 0.0, 0.0)
    s.set(pose=(2.5, 0.2, 0.0))
    s.evaluate()
    assert s["slip_rate"] == (0.4, 0.3, 0.1)


def test_random_profile_is_reproducible_for_a_seed() -> None:
    def series(seed):
        s = make(SlipDisturbance, step=1e-2, profile="random", seed=seed, bandwidth=2.0)
        out = []
        for _ in range(200):
            s.evaluate()
            out.append(s["slip_rate"] + s["disturbance"])
            s.step()
        return np.array(out)

    a, b, c = series(1), series(1), series(2)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert 0.05 < np.std(a[:, 0]) < 2.0
