"""Motor driver: ideal pass-through; DC mode against python-control's own simulation."""
from __future__ import annotations

import control
import numpy as np
import pytest

from twmr.components.motor import MotorDriver


def motor(**kw) -> MotorDriver:
    m = MotorDriver("motor", **kw)
    m.setup(0.0, 1.0)
    m.initialize()
    return m


def test_ideal_mode_passes_torque_exactly() -> None:
    m = motor()
    m.torque_command = (1.25, -3.5)
    m.evaluate(0.0)
    assert m.torque == (1.25, -3.5)


def test_dc_mode_steady_state_torque_equals_command() -> None:
    m = motor(mode="dc")
    m.torque_command = (6.0, -3.0)
    for n in range(200):
        m.evaluate(n * 1e-3)
        m.do_step(n * 1e-3, 1e-3)
    np.testing.assert_allclose(m.torque, (6.0, -3.0), rtol=1e-6)


def test_dc_current_loop_matches_python_control_closed_loop() -> None:
    """The PI + armature loop at step h against the continuous loop simulated by python-control:
    the difference is the ZOH/sampling error, which shrinks with h."""
    def cosim(h: float, T: float) -> tuple[np.ndarray, np.ndarray]:
        m = motor(mode="dc", bandwidth=300.0)
        m.torque_command = (3.0, 3.0)
        m.wheel_speed = (0.0, 0.0)
        ts, ys = [], []
        for n in range(int(round(T / h))):
            m.evaluate(n * h)
            ts.append(n * h)
            ys.append(m.torque[0])
            m.do_step(n * h, h)
        return np.array(ts), np.array(ys)

    m = motor(mode="dc", bandwidth=300.0)
    kt = m.gear * m.K_t
    pi = control.tf([m.L * 300.0, m.R * 300.0], [1.0, 0.0])
    arm = control.tf([1.0], [m.L, m.R])
    loop = control.feedback(pi * arm, 1) * kt  # torque per ampere of reference
    errs = []
    for h in (1e-3, 2.5e-4):
        t, y = cosim(h, 0.03)
        ref = control.forced_response(loop, T=t, U=np.full_like(t, 3.0 / kt)).outputs
        errs.append(np.max(np.abs(y - ref)))
    assert errs[1] < errs[0] and errs[1] < 0.15 * 3.0


def test_voltage_saturation_limits_the_current_rise() -> None:
    m = motor(mode="dc", V_max=1.0)
    m.torque_command = (40.0, 40.0)
    m.evaluate(0.0)
    m.do_step(0.0, 1e-4)
    # di/dt <= V_max / L over one step
    assert m.torque[0] <= m.gear * m.K_t * (1.0 / m.L) * 1e-4 * 1.0001


def test_current_limit() -> None:
    m = motor(mode="dc", I_max=10.0)
    m.torque_command = (1000.0, -1000.0)
    for n in range(500):
        m.evaluate(n * 1e-3)
        m.do_step(n * 1e-3, 1e-3)
    assert m.torque[0] == pytest.approx(10.0 * m.gear * m.K_t, rel=1e-6)
    assert m.torque[1] == pytest.approx(-10.0 * m.gear * m.K_t, rel=1e-6)


def test_encoder_integrates_the_wheel_speed() -> None:
    m = motor()
    m.wheel_speed = (2.0, -1.0)
    for n in range(100):
        m.do_step(n * 1e-2, 1e-2)
    assert m.angle == pytest.approx((2.0, -1.0))
    assert m.measured_speed == (2.0, -1.0)
