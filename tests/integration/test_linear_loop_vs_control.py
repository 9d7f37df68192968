"""A linear feedback loop built from engine blocks in a scenario, against python-control.

Loop: r = step -> e = r - y -> u = K e -> plant P(s) = 1 / (s^2 + 3 s + 2) (state space) -> y.
python-control simulates the same interconnection in continuous time (`control.feedback`,
`control.forced_response`). The co-simulation holds the plant input over each step (ZOH), so the
error is first order in h: it must be below a bound proportional to h, and halve when h halves.
"""
from __future__ import annotations

import control
import numpy as np
import pytest

from twmr.master import simulate
from twmr.scenario import loads

K = 5.0
SCENARIO = """
components:
  ref: {kind: step, parameters: {height: 1.0, time: 0.0}}
  err: {kind: sum, parameters: {k2: -1.0}}
  ctrl: {kind: gain, parameters: {k: %(K)r}}
  plant:
    kind: state_space
    parameters: {A: [[0.0, 1.0], [-2.0, -3.0]], B: [0.0, 1.0], C: [1.0, 0.0], D: 0.0}
connections:
  - ref.y -> err.u1
  - plant.y -> err.u2
  - err.y -> ctrl.u
  - ctrl.y -> plant.u
experiment: {start: 0.0, stop: 5.0, step: %(h)r, algorithm: %(alg)s}
record: {signals: [plant.y]}
"""


def cosim(h: float, alg: str = "gauss_seidel") -> tuple[np.ndarray, np.ndarray]:
    r = simulate(loads(SCENARIO % {"K": K, "h": h, "alg": alg}, source="loop.yaml"))
    return np.asarray(r["time"]), np.asarray(r["plant.y"])


def reference(t: np.ndarray) -> np.ndarray:
    plant = control.ss([[0.0, 1.0], [-2.0, -3.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
    loop = control.feedback(K * plant, 1)
    return control.forced_response(loop, T=t, U=np.ones_like(t)).outputs


@pytest.mark.parametrize("alg", ["gauss_seidel", "jacobi"])
def test_closed_loop_matches_python_control_to_first_order(alg: str) -> None:
    errs = []
    for h in (2e-3, 1e-3):
        t, y = cosim(h, alg)
        errs.append(np.max(np.abs(y - reference(t))))
    # |y_true| <= 1, loop gain bandwidth ~ sqrt(7) rad/s: the ZOH error is ~ K h / 2 at most
    assert errs[1] < K * 1e-3
    assert 1.7 < errs[0] / errs[1] < 2.3, errs  # first order: halving h halves the error


def test_static_gain_matches_python_control_dcgain() -> None:
    _t, y = cosim(1e-3)
    plant = control.tf([1.0], [1.0, 3.0, 2.0])
    assert y[-1] == pytest.approx(control.dcgain(control.feedback(K * plant, 1)), abs=2e-3)
