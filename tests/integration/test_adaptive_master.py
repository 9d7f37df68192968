"""The adaptive master (`experiment.algorithm: adaptive`) against python-control's continuous-time
answer, its step sizes around an input step, exact rollback of a real FMI 3.0 FMU, and refusal of
a block that cannot save its state.

Loop: r = step at t = 1 s -> e = r - y -> u = 5 e -> plant 1 / (s^2 + 3 s + 2) -> y. The plant is
exact for an input held over a step, so the co-simulation error is the coupling's (first order in
the communication step H); python-control gives the continuous closed loop.
"""
from __future__ import annotations

import math
from pathlib import Path

import control
import numpy as np
import pytest

from tests.fmu_build import build_c_fmu
from twmr.core.errors import ScenarioError
from twmr.master import Execution
from twmr.master.adaptive import Adaptive
from twmr.master.algorithm import Algorithm, algorithm_for
from twmr.observers.store import ResultStore
from twmr.scenario import loads

LOOP = """
components:
  ref: {kind: step, parameters: {height: 1.0, time: 1.0}}
  err: {kind: sum, parameters: {k2: -1.0}}
  ctrl: {kind: gain, parameters: {k: 5.0}}
  plant:
    kind: state_space
    parameters: {A: [[0.0, 1.0], [-2.0, -3.0]], B: [0.0, 1.0], C: [1.0, 0.0], D: 0.0}
connections:
  - ref.y -> err.u1
  - plant.y -> err.u2
  - err.y -> ctrl.u
  - ctrl.y -> plant.u
experiment: {start: 0.0, stop: 6.0, step: %(h)r, algorithm: %(alg)s}
record: {signals: [plant.y]}
"""
ADAPTIVE = "adaptive, rtol: 1.0e-2, atol: 1.0e-3"


def run(text: str) -> tuple[np.ndarray, Execution]:
    ex = Execution(loads(text, source="loop.yaml"), [store := ResultStore()])
    ex.run()
    return store.data(), ex


def analytic(t: np.ndarray) -> np.ndarray:
    """The continuous closed loop's response to the step at 1 s (python-control)."""
    plant = control.ss([[0.0, 1.0], [-2.0, -3.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
    fine = np.linspace(0.0, 6.0, 60001)
    response = control.forced_response(control.feedback(5.0 * plant, 1), fine,
                                       (fine >= 1.0).astype(float))
    return np.interp(t, fine, response.outputs)


def max_error(data: np.ndarray) -> float:
    return float(np.max(np.abs(data[:, 1] - analytic(data[:, 0]))))


def test_adaptive_meets_the_tolerance_with_fewer_steps_than_fixed() -> None:
    data, ex = run(LOOP % {"h": 1e-3, "alg": ADAPTIVE})
    report = ex.algorithm.report()
    error = max_error(data)
    assert error < 1e-2 * 0.75 + 1e-3  # rtol |y| + atol, |y| <= 0.75
    accepted = int(report["steps_accepted"])  # type: ignore[call-overload]
    assert accepted == len(data) - 1
    # the fixed step of the same accuracy: the largest multiple of 1 ms whose error is as small
    as_good = [h for h in (0.001, 0.002, 0.004, 0.008, 0.016)
               if max_error(run(LOOP % {"h": h, "alg": "gauss_seidel"})[0]) <= error]
    assert as_good, "no fixed step tried is as accurate"
    assert round(6.0 / max(as_good)) > 2 * accepted


def test_an_input_step_shrinks_the_step_then_it_grows_again() -> None:
    data, ex = run(LOOP % {"h": 1e-3, "alg": ADAPTIVE + ", max_step: 0.5"})
    algorithm = ex.algorithm
    assert isinstance(algorithm, Adaptive)
    steps = np.array([(a.n * 1e-3, a.k * 1e-3) for a in algorithm.history if a.accepted])
    # the rows come at the accepted points: their spacing is the accepted steps
    assert np.allclose(np.diff(data[:, 0]), steps[:, 1], atol=1e-12)
    before = steps[steps[:, 0] < 1.0]
    after = steps[(steps[:, 0] >= 1.0) & (steps[:, 0] < 2.0)]
    late = steps[(steps[:, 0] > 4.0) & (steps.sum(axis=1) < 6.0)]  # the last ends at the stop
    assert before[:, 1].max() >= 0.25  # nothing happens: doubled from 1 ms
    assert np.any(np.isclose(steps[:, 0] + steps[:, 1], 1.0))  # a step ends at the event
    assert after[:, 1].min() <= 0.02  # the transient after the jump: small steps
    assert late[:, 1].min() >= 0.1  # settled: large again, up to max_step
    assert late[:, 1].max() == pytest.approx(0.5)
    assert algorithm.report()["steps_rejected"] > 0


@pytest.fixture(scope="module")
def lag3(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_c_fmu("lag3", tmp_path_factory.mktemp("fmus"), fmi3=True)


FMU_LOOP = """
components:
  ref: {kind: step, parameters: {height: 1.0, time: 0.2}}
  err: {kind: sum, parameters: {k2: -1.0}}
  lag: {kind: fmu, parameters: {path: %(path)s, k: 4.0, T: 0.1}}
connections:
  - ref.y -> err.u1
  - lag.y[1] -> err.u2
  - err.y -> lag.u[1]
  - err.y -> lag.u[2]
experiment: {start: 0.0, stop: 2.0, step: 1.0e-3, algorithm: %(alg)s}
record: {signals: [lag.y]}
"""


class Replay(Algorithm):
    """A fresh run of the accepted steps only: at each, inputs written and the two half steps,
    no state saved or restored."""

    variable_step = True

    def __init__(self, accepted: list[tuple[int, int]]):
        self.accepted = accepted

    def prepare(self, system, record, decimation, check_finite=True) -> None:
        self.c = system.components

    def inputs(self) -> None:
        ref, err, lag = self.c["ref"], self.c["err"], self.c["lag"]
        err.u1, err.u2 = ref.y, lag.y[0]
        err.evaluate(0.0)
        lag.u = (err.y, err.y)

    def advance(self, n0: int, n1: int, rows: list) -> int:
        n = n0
        for start, k in self.accepted:
            if start < n0:
                continue
            t, half = start * 1e-3, k // 2
            self.inputs()
            rows.append((t, *self.c["lag"].y))
            for comp in self.c.values():
                comp.do_step(t, half * 1e-3 if k > 1 else 1e-3)
            if k > 1:
                self.inputs()
                for comp in self.c.values():
                    comp.do_step(t + half * 1e-3, (k - half) * 1e-3)
            n = start + k
        return n

    def finish(self, n: int, rows: list) -> None:
        self.inputs()
        rows.append((n * 1e-3, *self.c["lag"].y))


def test_rollback_restores_an_fmu_exactly(lag3: Path) -> None:
    data, ex = run(FMU_LOOP % {"path": lag3, "alg": "adaptive, rtol: 1.0e-4, atol: 1.0e-6"})
    algorithm = ex.algorithm
    assert isinstance(algorithm, Adaptive)
    assert algorithm.report()["steps_rejected"] > 0
    accepted = [(a.n, a.k) for a in algorithm.history if a.accepted]
    fresh = Execution(loads(FMU_LOOP % {"path": lag3, "alg": "gauss_seidel"}, source="l.yaml"),
                      [store := ResultStore()], algorithm=Replay(accepted))
    fresh.run()
    assert np.array_equal(store.data(), data)  # bit for bit: every rejected step undone
    # and the lag follows y' = (k e - y) / T, e = r - y: y -> 0.8 with time constant T / 5
    t = data[:, 0]
    y = 0.8 * (1.0 - np.exp(-(t - 0.2) * 5.0 / 0.1)) * (t >= 0.2)
    assert math.isclose(data[-1, 1], 0.8, abs_tol=1e-3)
    assert np.max(np.abs(data[:, 1] - y)) < 0.05


def test_a_block_that_cannot_save_its_state_is_refused_at_check() -> None:
    text = """
components:
  drive: {kind: can_drive, parameters: {channel: adaptive25-refusal}}
open: [drive.torque_command, drive.wheel_speed]
experiment: {stop: 0.1, step: 1.0e-3, algorithm: adaptive, realtime: false}
"""
    with pytest.raises(ScenarioError) as info:
        algorithm_for(loads(text, source="hil.yaml"))
    message = str(info.value)
    assert "'drive'" in message and "adaptive" in message and "Fix:" in message
    assert "hil.yaml" in message


def test_tolerances_need_the_adaptive_algorithm() -> None:
    with pytest.raises(ScenarioError, match="applies to algorithm: adaptive"):
        loads(LOOP % {"h": 1e-3, "alg": "gauss_seidel, rtol: 1.0e-3"}, source="loop.yaml")
    with pytest.raises(ScenarioError, match="whole multiple"):
        loads(LOOP % {"h": 1e-3, "alg": "adaptive, max_step: 0.0015"}, source="loop.yaml")


@pytest.mark.parametrize("interface", ["model_exchange", "co_simulation"])
def test_a_bouncing_ball_fmu_alone_takes_few_steps_and_stays_exact(
        tmp_path: Path, interface: str) -> None:
    """An FMU alone has no coupling error: the step grows to max_step, and the two half steps
    after each restore follow the analytic bounces (a state not restored would run twice)."""
    from tests.integration.test_fmu_events import ball_height

    path = build_c_fmu("bounce3", tmp_path, fmi3=True)
    data, ex = run(f"""
components:
  ball: {{kind: fmu, parameters: {{path: {path}, interface: {interface}}}}}
experiment: {{stop: 2.0, step: 1.0e-3, algorithm: adaptive, rtol: 1.0e-6, atol: 1.0e-8,
             max_step: 0.25}}
record: {{signals: [ball.h]}}
""")
    report = ex.algorithm.report()
    assert report["step_max_s"] == pytest.approx(0.25)
    assert int(report["steps_accepted"]) < 20  # type: ignore[call-overload]
    tol = 1e-4 if interface == "model_exchange" else 1e-9  # ME: the FMU's solver (CVODE)
    assert np.max(np.abs(data[:, 1] - ball_height(data[:, 0]))) < tol
    with pytest.raises(ScenarioError, match="is larger than max_step"):
        loads(LOOP % {"h": 1e-3, "alg": "adaptive, min_step: 0.004, max_step: 0.002"},
              source="loop.yaml")
