"""The `lqr` tracking controller: its gains are python-control's LQR of the linearised error model
(two double integrators x1'' = -u, with the integral of x1 as a state for LQI), its torque is
eq. (32)'s computed torque with the LQR term in place of the sliding-mode one (the same error
model as the SMC: an SMC of k = 0 and vartheta = k_d with d_hat = 0 gives the torque of an LQR
of k_p = 0 with no integral), the integral is the step sum of x1, and the paper's trajectory 1
without slip is tracked, in the Python schedule and the compiled loop alike."""
from __future__ import annotations

import control
import numpy as np
import pytest

import twmr
from twmr.components.lqr import LqrController, lqr_gains
from twmr.components.smc import SmcController
from twmr.testing import Harness

pytestmark = pytest.mark.timeout(300)

A2 = np.array([[0.0, 1.0], [0.0, 0.0]])
A3 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])


@pytest.mark.parametrize("qp,qv", [(400.0, 1.0), (1e5, 1e4), (3.0, 0.0)])
def test_lqr_gains_are_python_controls(qp: float, qv: float) -> None:
    K, _, _ = control.lqr(A2, [[0.0], [-1.0]], np.diag([qp, qv]), [[1.0]])
    k_i, k_p, k_d = lqr_gains(0.0, qp, qv)
    assert k_i == 0.0
    assert [k_p, k_d] == pytest.approx(-np.asarray(K)[0], rel=1e-9)


@pytest.mark.parametrize("qi,qp,qv", [(100.0, 400.0, 1.0), (1e4, 1e5, 1e4), (1e6, 1e8, 0.1),
                                      (1.0, 10.0, 1e6)])
def test_lqi_gains_are_python_controls(qi: float, qp: float, qv: float) -> None:
    K, _, poles = control.lqr(A3, [[0.0], [0.0], [-1.0]], np.diag([qi, qp, qv]), [[1.0]])
    gains = lqr_gains(qi, qp, qv)
    assert list(gains) == pytest.approx(-np.asarray(K)[0], rel=1e-7)
    closed = A3 + np.array([[0.0], [0.0], [-1.0]]) @ np.array([gains])
    assert np.sort_complex(np.linalg.eigvals(closed)) == pytest.approx(
        np.sort_complex(np.asarray(poles)), rel=1e-6)


def test_a_vanishing_integral_weight_gives_the_lqr_gains() -> None:
    """Where a Riccati solver fails (q_integral 5e-324: scipy finds no finite solution), the
    gains tend to the LQR's without the integral."""
    k_i, k_p, k_d = lqr_gains(5e-324, 1e5, 1e4)
    assert k_i == pytest.approx(0.0, abs=1e-150)
    assert (k_p, k_d) == pytest.approx(lqr_gains(0.0, 1e5, 1e4)[1:], rel=1e-9)


def _torque(cls: type, **parameters: object) -> tuple[float, float]:
    h = Harness(cls, name="ctrl", parameters={"drive": "backward", "torque_limit": 0.0,
                                              "eps_singular": 1e-3, **parameters}, stop=1.0)
    h.set(pose=(0.1, -0.2, 0.3), wheel_speed=(2.0, 1.5), ref_position=(0.5, 0.4),
                 ref_velocity=(-0.8, 0.6), ref_acceleration=(0.0, 0.0))
    h.initialize()
    return tuple(h.component.torque)  # type: ignore[return-value]


def test_the_torque_is_the_sliding_laws_with_the_lqr_term() -> None:
    """With no switching term (k = 0) the SMC's v is (vartheta I + E) x1': the LQR's with k_d =
    vartheta and k_p = k_i = 0 (q_position -> 0, q_velocity = vartheta^2)."""
    vartheta = 7.0
    smc = _torque(SmcController, k=0.0, vartheta=vartheta, lam=3.0, phi=0.2)
    lqr = _torque(LqrController, q_position=1e-16, q_velocity=vartheta ** 2)
    assert lqr == pytest.approx(smc, rel=1e-6, abs=1e-9)
    other = _torque(LqrController, q_position=400.0, q_velocity=1.0)
    assert abs(other[0] - smc[0]) > 1.0  # the position term changes it


def test_the_sliding_mode_gains_are_not_its_parameters() -> None:
    names = set(LqrController.declared())
    assert {"q_position", "q_velocity", "q_integral", "integral", "torque", "error"} <= names
    assert not names & {"lam", "vartheta", "k", "phi", "s"}
    with pytest.raises(Exception, match="q_position must be above 0"):
        Harness(LqrController, name="ctrl", parameters={"q_position": 0.0}).initialize()


def test_trajectory_1_without_slip_is_tracked_alike_in_python_and_compiled() -> None:
    sets = ["slip.profile=none", "ctrl.q_integral=100.0", "experiment.stop=10"]
    rows = {}
    for mode in ("off", "on"):
        result = twmr.simulate(twmr.load("scenarios/paper_trajectory1_lqr.yaml", sets), None,
                               compiled=mode, metrics=["tracking"])
        rows[mode] = result
    py, co = rows["off"], rows["on"]
    assert np.array_equal(py.values, co.values)
    metrics = py.summary["metrics"]
    assert metrics["peak_error_x"] < 0.3 and metrics["settling_time_x"] < 2.0
    t = np.asarray(py["time"])
    late = t >= 5.0
    e = np.hypot(np.asarray(py["ctrl.error[1]"])[late] + 0.05,
                 np.asarray(py["ctrl.error[2]"])[late])
    # the look-ahead point (L = -0.05 m, backward) within a few cm of the target: what is left
    # is the target's acceleration, which no law here feeds forward
    assert e.max() < 0.05 and e.mean() < 0.03


def test_the_integral_is_the_step_sum_of_x1_and_held_while_saturated() -> None:
    inputs = {"pose": (0.1, -0.2, 0.3), "wheel_speed": (2.0, 1.5), "ref_position": (0.5, 0.4),
              "ref_velocity": (-0.8, 0.6), "ref_acceleration": (0.0, 0.0)}
    h = Harness(LqrController, name="ctrl", parameters={
        "drive": "backward", "torque_limit": 0.0, "q_integral": 100.0, "lookahead": 0.05})
    h.set(**inputs).initialize().step(5, **inputs)
    e1, e2 = h.component.error
    assert h.component.integral == pytest.approx((5e-3 * (e1 + 0.05), 5e-3 * e2), rel=1e-12)
    held = Harness(LqrController, name="ctrl", parameters={
        "drive": "backward", "torque_limit": 1e-3, "q_integral": 100.0})
    held.set(**inputs).initialize().step(5, **inputs)
    assert held.component.integral == (0.0, 0.0)  # the torque is limited at every step
