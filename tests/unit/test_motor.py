"""Motor driver: ideal pass-through; DC mode against python-control (its zoh discretisation and
its simulation of the closed current loop)."""
from __future__ import annotations

import control
import numpy as np
import pytest

from twmr.components.motor import MotorDriver, armature_zoh
from twmr.testing import Harness


def motor(step: float = 1e-3, **kw) -> Harness:
    """An initialized harness around the motor driver with parameters `kw`, on [0, 1] s at
    communication step `step`."""
    return Harness(MotorDriver, name="motor", parameters=kw, stop=1.0, step=step).initialize()


def test_ideal_mode_passes_torque_exactly() -> None:
    m = motor()
    m.set(torque_command=(1.25, -3.5))
    m.evaluate()
    assert m["torque"] == (1.25, -3.5)


@pytest.mark.parametrize("h", [1e-5, 1e-3, 0.05])
@pytest.mark.parametrize("R, L, K_e, gear", [(0.3, 3e-4, 0.06, 20.0), (2.0, 1e-2, 0.1, 5.0)])
def test_armature_discretisation_is_control_c2d_zoh(R, L, K_e, gear, h) -> None:
    """The closed form against python-control's zoh of di/dt = (-R i + V - K_e N omega) / L."""
    arm = control.ss([[-R / L]], [[1.0 / L, -K_e * gear / L]], [[1.0]], [[0.0, 0.0]])
    d = control.c2d(arm, h, method="zoh")
    a, b_v, b_w = armature_zoh(R, L, K_e, gear, h)
    np.testing.assert_allclose((a, b_v, b_w), (d.A[0, 0], d.B[0, 0], d.B[0, 1]), rtol=1e-11,
                               atol=1e-300)


def test_dc_mode_steady_state_torque_equals_command() -> None:
    m = motor(mode="dc")
    m.set(torque_command=(6.0, -3.0))
    m.step(200)  # evaluate, then do_step, 200 times at 1 ms
    np.testing.assert_allclose(m["torque"], (6.0, -3.0), rtol=1e-6)


def test_dc_current_loop_matches_python_control_closed_loop() -> None:
    """The PI + armature loop at step h against the continuous loop simulated by python-control:
    the difference is the ZOH/sampling error, which shrinks with h."""
    def cosim(h: float, T: float) -> tuple[np.ndarray, np.ndarray]:
        m = motor(step=h, mode="dc", bandwidth=300.0)
        m.set(torque_command=(3.0, 3.0), wheel_speed=(0.0, 0.0))
        ts, ys = [], []
        for _ in range(round(T / h)):
            m.evaluate()
            ts.append(m.t)  # n h
            ys.append(m["torque"][0])
            m.step()
        return np.array(ts), np.array(ys)

    m = motor(mode="dc", bandwidth=300.0)
    kt = m["gear"] * m["K_t"]
    pi = control.tf([m["L"] * 300.0, m["R"] * 300.0], [1.0, 0.0])
    arm = control.tf([1.0], [m["L"], m["R"]])
    loop = control.feedback(pi * arm, 1) * kt  # torque per ampere of reference
    errs = []
    for h in (1e-3, 2.5e-4):
        t, y = cosim(h, 0.03)
        ref = control.forced_response(loop, T=t, U=np.full_like(t, 3.0 / kt)).outputs
        errs.append(np.max(np.abs(y - ref)))
    assert errs[1] < errs[0] and errs[1] < 0.15 * 3.0


def test_voltage_saturation_limits_the_current_rise() -> None:
    m = motor(step=1e-4, mode="dc", V_max=1.0)
    m.set(torque_command=(40.0, 40.0))
    m.step()  # evaluate(0.0), then do_step(0.0, 1e-4)
    # di/dt <= V_max / L over one step
    assert m["torque"][0] <= m["gear"] * m["K_t"] * (1.0 / m["L"]) * 1e-4 * 1.0001


def test_current_limit() -> None:
    m = motor(mode="dc", I_max=10.0)
    m.set(torque_command=(1000.0, -1000.0))
    m.step(500)  # evaluate, then do_step, 500 times at 1 ms
    assert m["torque"][0] == pytest.approx(10.0 * m["gear"] * m["K_t"], rel=1e-6)
    assert m["torque"][1] == pytest.approx(-10.0 * m["gear"] * m["K_t"], rel=1e-6)


def test_encoder_integrates_the_wheel_speed() -> None:
    m = motor(step=1e-2)
    m.set(wheel_speed=(2.0, -1.0))
    m.step(100)  # 1 s at 10 ms
    assert m["angle"] == pytest.approx((2.0, -1.0))
    assert m["measured_speed"] == (2.0, -1.0)


@pytest.mark.parametrize("mode, limit", [("ideal", 50.0), ("dc", 48.0)])
def test_an_implausible_command_is_warned_about_once(mode, limit, caplog) -> None:
    m = motor(mode=mode)
    with caplog.at_level("WARNING", logger="twmr.run"):
        m.set(torque_command=(1.9 * limit, -1.9 * limit))  # within twice the limit: no word
        m.step(3)
        m.set(torque_command=(9.2e4, 0.0))
        m.step(3)
        m.set(torque_command=(-5e5, 0.0))
        m.step(3)
    warned = [r.getMessage() for r in caplog.records if r.name == "twmr.run"]
    assert len(warned) == 1 and "92000" in warned[0].replace(",", "").replace("9.2e+04", "92000")
    assert f"limit of {limit:g} N.m" in warned[0]
