"""ASMC / SMC: the law of eqs (9)-(32) against an independent numpy transcription, the
singularity, the adaptive law (33), V of eq. (27) decreasing on the nominal closed loop."""
from __future__ import annotations

import math

import numpy as np
import pytest

from twmr.components.asmc import AsmcController
from twmr.components.plant import TwmrPlant
from twmr.components.smc import SmcController
from twmr.testing import Harness

R, B, LAM, VTH, K = 0.15, 0.75, 13.0, 20.0, 20.0


def controller(cls=AsmcController, **kw) -> Harness:
    """An initialized harness around a controller with parameters `kw`, on [0, 10] s, h = 1 ms;
    the law as printed (sgn, no torque limit, 1 mm singularity clamp) unless `kw` says otherwise."""
    kw = {"phi": 0.0, "torque_limit": 0.0, "eps_singular": 1e-3, "drive": "backward", **kw}
    return Harness(cls, name="ctrl", parameters=kw, stop=10.0).initialize()


def numpy_law(c, pose, nu, pT, vT, d_hat, L):
    """Eqs (9), (15), (16), (21)-(25), (32) with numpy matrices; `c` gives the nominal m11, m12
    (the controller's own, not ports) and m_G."""
    x, y, th = pose
    Rm = np.array([[math.cos(th), math.sin(th)], [-math.sin(th), math.cos(th)]])
    e = Rm @ (np.array(pT) - np.array([x, y]))  # eq. (9)
    kappa = np.array([[(e[1] / B - 1) * R / 2, -(e[1] / B + 1) * R / 2],
                      [-e[0] * R / (2 * B), e[0] * R / (2 * B)]])  # eq. (15)
    assert np.linalg.det(kappa) == pytest.approx(-R**2 * e[0] / (2 * B))
    M = np.array([[c.m11, c.m12], [c.m12, c.m11]])
    omega = R * (nu[0] - nu[1]) / (2 * B)
    Bm = c.m_G * R**2 / (2 * B) * omega * np.array([[0, 1], [-1, 0]])
    x1 = e - np.array([L, 0.0])
    x1d = kappa @ nu + Rm @ np.array(vT)
    x2 = x1d + LAM * x1
    s = VTH * x1 + x2  # eq. (25)
    Z = kappa @ np.linalg.inv(M)
    E = -kappa @ np.linalg.inv(M) @ Bm @ np.linalg.inv(kappa)
    tau = -np.linalg.inv(Z) @ ((VTH * np.eye(2) + E) @ (x2 - LAM * x1) + d_hat + K * np.sign(s))
    return tau, s, e


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("L", [0.0, 0.05, -0.1])
def test_law_matches_numpy_transcription(seed: int, L: float) -> None:
    rng = np.random.default_rng(seed)
    c = controller(lookahead=abs(L), drive="forward" if L >= 0 else "backward",
                   d_hat0=tuple(rng.normal(size=2)))
    c.set(pose=tuple(rng.normal(size=3)), wheel_speed=tuple(rng.normal(size=2) * 5))
    c.set(ref_position=tuple(rng.normal(size=2)), ref_velocity=tuple(rng.normal(size=2)))
    c.evaluate()
    tau, s, e = numpy_law(c.component, c["pose"], np.array(c["wheel_speed"]), c["ref_position"],
                          c["ref_velocity"], np.array(c["d_hat"]), L)
    np.testing.assert_allclose(c["torque"], tau, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(c["s"], s, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(c["error"], e, rtol=1e-12, atol=1e-12)


def test_lookahead_point_has_the_same_kappa() -> None:
    """d/dt of the error of P = M + L(cos, sin) equals d/dt e_M: finite differences of both."""
    L, h = 0.3, 1e-6
    th0, w = 0.4, 0.9
    pT = np.array([2.0, 1.0])

    def errs(t):
        th = th0 + w * t
        M = np.array([0.1 * t, -0.2 * t])
        Rm = np.array([[math.cos(th), math.sin(th)], [-math.sin(th), math.cos(th)]])
        return Rm @ (pT - M), Rm @ (pT - M - L * np.array([math.cos(th), math.sin(th)]))

    (a0, b0), (a1, b1) = errs(0.0), errs(h)
    np.testing.assert_allclose((a1 - a0) / h, (b1 - b0) / h, atol=1e-6)


def test_torque_is_finite_at_the_singular_point() -> None:
    c = controller(lookahead=0.0)
    c.set(pose=(1.0, 2.0, 0.0), ref_position=(1.0, 2.5))  # target straight to the side: e_p1 = 0
    c.set(wheel_speed=(1.0, 1.0), ref_velocity=(0.5, 0.0))
    c.evaluate()
    assert c["error"][0] == 0.0
    assert all(math.isfinite(v) for v in c["torque"])


def test_adaptive_estimate_follows_eta_s() -> None:
    c = controller(eta=7.0)
    c.set(pose=(0.0, 0.0, 0.1), ref_position=(1.0, 0.3), ref_velocity=(0.5, 0.1))
    c.set(wheel_speed=(2.0, 1.0))
    h = c.h  # 1 ms
    expected = np.zeros(2)
    for _ in range(50):
        c.evaluate()
        expected += 7.0 * np.array(c["s"]) * h  # eq. (33), s held over each step
        c.step()
    np.testing.assert_allclose(c["d_hat"], expected, rtol=1e-12)


def test_smc_is_asmc_without_adaptation() -> None:
    a, s = controller(AsmcController, eta=0.0), controller(SmcController)
    for c in (a, s):
        c.set(pose=(0.2, 0.1, 0.3), ref_position=(1.0, 0.5), ref_velocity=(0.3, 0.4))
        c.set(wheel_speed=(1.0, 3.0))
        c.step(5)  # evaluate, then do_step, at t = 0, 1, ..., 4 ms
    assert a["torque"] == s["torque"]


def test_nominal_closed_loop_drives_lyapunov_function_down() -> None:
    """Nominal plant, no slip or disturbance: V = x1^2/2 + s^2/2 of eq. (27) (d~ term left out:
    d is not observable) falls by orders of magnitude from a 0.5 m offset."""
    plant = Harness(TwmrPlant, name="plant", initial={"pose": (0.0, 0.0, 0.0)}, stop=5.0)
    plant.initialize()
    ctrl = controller(lookahead=0.05, drive="forward", phi=0.5)

    def V() -> float:
        x1 = np.array(ctrl["error"]) - np.array([0.05, 0.0])
        return 0.5 * x1 @ x1 + 0.5 * np.dot(ctrl["s"], ctrl["s"])

    values = []
    for _ in range(3000):
        t = ctrl.t  # n h, the same for both harnesses
        ctrl.set(pose=plant["pose"], wheel_speed=plant["wheel_speed"])
        ctrl.set(ref_position=(0.5 + 0.5 * t, 0.1), ref_velocity=(0.5, 0.0))
        ctrl.evaluate()
        plant.set(torque=ctrl["torque"])
        values.append(V())
        ctrl.step()
        plant.step()
    assert values[-1] < 1e-3 * values[0]
    assert max(values[1000:]) < 0.01 * values[0]
