"""TWMR plant against analytic answers: eq. (8) by hand for Table I, a straight line at equal
torques, a rotation on the spot, energy with B alone, a disturbance balancing the torque, slip
moving the robot, RK4's order."""
from __future__ import annotations

import math

import numpy as np
import pytest

from twmr.components.plant import TwmrPlant
from twmr.testing import Harness

A, R, B = 0.3, 0.15, 0.75
#: eq. (8) for Table I (a 0.3, I_G 15.625, I_D 0.0025, I_W 0.1, r 0.15, b 0.75, m_W 1, m_G 30)
#: by hand: r^2/(4b^2) = 0.01, I_G + 2 I_D = 15.63, a^2/b^2 = 0.16, r/(4b) = 0.05
M11 = 30 * (0.005625 + 0.0009) + 0.01 * 15.63 + 2 * 0.0225 + 0.1  # 0.49705
M12 = 30 * (0.005625 - 0.0009) - 0.01 * 15.63  # -0.01455
Q1 = 30 * 0.15 / 4 * 1.16 + 0.05 * 15.63  # 2.0865
Q2 = 30 * 0.15 / 4 * 0.84 - 0.05 * 15.63  # 0.1635


def plant(initial: dict | None = None, step: float = 1e-3, **kw) -> Harness:
    """An initialized harness around the plant with parameters `kw` and start values `initial`,
    on [0, 10] s at communication step `step`."""
    return Harness(TwmrPlant, name="plant", parameters=kw, initial=initial, stop=10.0,
                   step=step).initialize()


def test_inertia_terms_are_eq_8_for_table_i() -> None:
    p = plant().component
    assert (p.m11, p.m12, p.q1, p.q2) == pytest.approx((M11, M12, Q1, Q2), rel=1e-13)


def test_scale_multiplies_every_mass_and_inertia() -> None:
    p = plant(scale=1.25).component
    assert (p.m11, p.m12, p.q1, p.q2) == pytest.approx(
        (1.25 * M11, 1.25 * M12, 1.25 * Q1, 1.25 * Q2), rel=1e-13)


def test_equal_torques_drive_a_straight_line_at_the_accelerations_of_eq_8() -> None:
    """tau_R = tau_L = tau from rest, no slip: varpi = 0, so B = C = 0 and (m11 + m12) phi'' =
    tau; M moves along theta's direction by r phi'' t^2 / 2 (RK4 is exact for a polynomial)."""
    theta, tau, T = 0.4, 1.5, 1.0
    p = plant(initial={"pose": (1.0, -2.0, theta)})
    p.set(torque=(tau, tau))
    p.step(1000)  # 1 s at 1 ms
    acc = tau / (M11 + M12)
    x, y, th = p["pose"]
    assert th == theta
    assert p["wheel_speed"] == pytest.approx((acc * T, acc * T), rel=1e-12)
    dist = R * acc * T * T / 2
    assert (x, y) == pytest.approx((1.0 + dist * math.cos(theta), -2.0 + dist * math.sin(theta)),
                                   rel=1e-12)
    assert p["com"] == pytest.approx((x + A * math.cos(th), y + A * math.sin(th)), rel=1e-12)


def test_opposite_torques_turn_on_the_spot_when_the_platform_mass_is_negligible() -> None:
    """m_G -> 0 removes B, C and G: tau_R = -tau_L = tau from rest gives (m11 - m12) phi_R'' =
    tau, beta = 0 (M stays put) and theta = r tau t^2 / (2 b (m11 - m12))."""
    tau, T = 0.8, 1.0
    p = plant(initial={"pose": (0.5, 0.25, 0.0)}, m_G=1e-6)
    p.set(torque=(tau, -tau))
    p.step(1000)
    c = p.component
    x, y, th = p["pose"]
    acc = tau / (c.m11 - c.m12)
    assert (x, y) == pytest.approx((0.5, 0.25), abs=1e-6)
    assert p["wheel_speed"] == pytest.approx((acc * T, -acc * T), rel=1e-6)
    assert th == pytest.approx(R * tau * T * T / (2 * B * (c.m11 - c.m12)), rel=1e-6)


def test_energy_is_conserved_without_torque_slip_or_disturbance() -> None:
    """B is skew-symmetric: nu' M nu / 2 is constant while B trades speed between the wheels."""
    M = np.array([[M11, M12], [M12, M11]])
    p = plant(initial={"wheel_speed": (3.0, -1.0)})
    e0 = 0.5 * np.array((3.0, -1.0)) @ M @ np.array((3.0, -1.0))
    p.step(2000)  # 2 s at 1 ms
    nu = np.array(p["wheel_speed"])
    assert 0.5 * nu @ M @ nu == pytest.approx(e0, rel=1e-9)
    assert abs(nu[0] - 3.0) > 1e-3  # B did exchange energy between the wheels


def test_a_disturbance_equal_to_the_torque_leaves_the_robot_at_rest() -> None:
    p = plant(initial={"pose": (0.0, 0.0, 1.0)})
    p.set(torque=(2.0, -3.0), disturbance=(2.0, -3.0))
    p.step(100)
    assert p["pose"] == (0.0, 0.0, 1.0) and p["wheel_speed"] == (0.0, 0.0)


def test_held_slip_rates_move_the_robot_with_locked_wheels() -> None:
    """Wheels at rest held by the torque that balances the slip accelerations (zero here): M moves
    by the slip rates alone, eqs (2), (3), (11): beta = (mu_R' + mu_L') / 2, lateral delta'."""
    p = plant(initial={"pose": (0.0, 0.0, 0.0)})
    p.set(slip_rate=(0.2, 0.2, 0.1))
    p.step(1000)
    x, y, th = p["pose"]
    assert (x, y, th) == pytest.approx((0.2, 0.1, 0.0), abs=1e-12)


def run(internal_step: float) -> np.ndarray:
    p = plant(initial={"wheel_speed": (1.0, 0.2)}, step=1.0, internal_step=internal_step)
    p.set(slip_rate=(0.3, -0.2, 0.1), slip_accel=(0.5, 0.1, -0.2), disturbance=(0.4, -0.1))
    p.set(torque=(2.0, -1.0))
    p.step()  # one communication step of 1 s: do_step(0.0, 1.0)
    return np.array(p["pose"] + p["wheel_speed"])


def test_rk4_is_fourth_order() -> None:
    exact = run(1e-4)
    e1 = np.max(np.abs(run(0.1) - exact))
    e2 = np.max(np.abs(run(0.05) - exact))
    assert 10.0 < e1 / e2 < 22.0, e1 / e2
