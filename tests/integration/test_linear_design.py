"""`twmr.linear_design`: controllers designed on the linear model of a scenario, against designs
python-control and scipy make on the exact zero-order-hold model of the same plant (the
mass-spring-damper of test_linearize): LQG gives the closed-loop poles of dlqr and the Kalman
predictor designed there (the realisation ERA chose does not matter), pole placement puts them
where asked, the controller written as a `state_space` block and wired to the plant in a
scenario gives the discrete closed loop's response step for step, and bad input is refused."""
from __future__ import annotations

import control
import numpy as np
import pytest
import yaml
from scipy.linalg import block_diag, solve_discrete_are

import twmr
from tests.integration.test_linearize import MSD, analytic_msd
from twmr.core.errors import CosimError
from twmr.linear_design import design

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def model():
    return twmr.linearize(twmr.load(MSD), ["msd.u"], ["msd.y"], at=1.0, horizon=80)


def test_lqg_gives_the_closed_loop_poles_of_the_design_on_the_exact_model(model) -> None:
    q, r, w, v = 400.0, 0.5, 2.0, 1e-3
    ours = design(model, "lqg", q=q, r=r, w=w, v=v)
    ref = analytic_msd()
    A, B, C = np.asarray(ref.A), np.asarray(ref.B), np.asarray(ref.C)
    K, _, _ = control.dlqr(A, B, C.T @ C * q, np.array([[r]]))
    P = solve_discrete_are(A.T, C.T, B @ B.T * w, np.array([[v]]))
    L = A @ P @ C.T @ np.linalg.inv(C @ P @ C.T + v)
    expected = np.concatenate([np.linalg.eigvals(A - B @ K), np.linalg.eigvals(A - L @ C)])
    assert np.sort_complex(ours.closed_loop_poles()) == pytest.approx(
        np.sort_complex(expected), abs=1e-6)
    assert np.all(np.abs(ours.closed_loop_poles()) < 1)
    gm, pm, _, _ = ours.margins()
    assert gm > 1 and pm > 0  # a stabilising loop has positive margins


def test_pole_placement_puts_the_poles_where_asked(model) -> None:
    poles, observer = [0.95, 0.9], [0.6, 0.5]
    ours = design(model, "place", poles=poles, observer_poles=observer)
    assert np.sort_complex(ours.closed_loop_poles()) == pytest.approx(
        np.sort_complex(np.array(poles + observer, dtype=complex)), abs=1e-8)


def test_the_controller_block_closes_the_loop_as_the_discrete_design_does(model, tmp_path
                                                                           ) -> None:
    """The plant starts displaced (x0 = 0.1 m) with the LQG controller wired in: its output,
    step for step, equals the discrete closed loop of the exact plant model and the designed
    controller (python-control's initial response), and decays faster than the plant alone."""
    ours = design(model, "lqg", q=400.0, r=0.5, w=2.0, v=1e-3)
    block = yaml.safe_load(ours.block_yaml("ctrl"))
    scenario = yaml.safe_load(MSD)
    scenario["components"] = {"msd": scenario["components"]["msd"], **block}
    scenario["components"]["msd"]["parameters"]["x0"] = [0.1, 0.0]
    scenario["connections"] = ["msd.y -> ctrl.u", "ctrl.y -> msd.u"]
    scenario["experiment"]["stop"] = 3.0
    scenario["record"] = {"signals": ["msd.y"]}
    result = twmr.simulate(twmr.load(yaml.safe_dump(scenario)))
    y = np.asarray(result.data["msd.y"], dtype=float)
    closed = control.feedback(analytic_msd(), ours.controller(), sign=1)
    n = np.asarray(closed.A).shape[0]
    x0 = np.zeros(n)
    x0[0] = 0.1
    expected = control.initial_response(closed, T=np.arange(len(y)) * model.dt, X0=x0).outputs
    np.testing.assert_allclose(y, np.ravel(expected), atol=1e-9)
    # closed-loop time constant 0.73 s against the plant's own 5 s: within 0.1 of the start
    # over the last second (the plant alone would still be at about 0.6 of it)
    assert np.abs(y[-100:]).max() < 0.1 * 0.1


def test_lqi_gives_the_poles_of_the_augmented_design_and_no_steady_error(model, tmp_path
                                                                         ) -> None:
    """LQI: the closed-loop poles are those of dlqr on the exact model augmented with an
    output integrator, and the Kalman predictor's; wired to the plant with a constant force
    on it (1 N from 0.5 s), the controller's output brings the displacement back to 0 (LQG
    leaves the steady error python-control's closed loop predicts for it)."""
    q, r, w, v, qi = 400.0, 0.5, 2.0, 1e-3, 50.0
    ours = design(model, "lqi", q=q, r=r, w=w, v=v, qi=qi)
    ref = analytic_msd()
    A, B, C = np.asarray(ref.A), np.asarray(ref.B), np.asarray(ref.C)
    Aa = np.block([[A, np.zeros((2, 1))], [C, np.eye(1)]])
    Ba = np.vstack([B, np.zeros((1, 1))])
    K, _, _ = control.dlqr(Aa, Ba, block_diag(C.T @ C * q, [[qi]]), np.array([[r]]))
    P = solve_discrete_are(A.T, C.T, B @ B.T * w, np.array([[v]]))
    L = A @ P @ C.T @ np.linalg.inv(C @ P @ C.T + v)
    expected = np.concatenate([np.linalg.eigvals(Aa - Ba @ K), np.linalg.eigvals(A - L @ C)])
    assert np.sort_complex(ours.closed_loop_poles()) == pytest.approx(
        np.sort_complex(expected), abs=1e-6)
    finals = {}
    for method in ("lqi", "lqg"):
        made = design(model, method, q=q, r=r, w=w, v=v, qi=qi)
        block = yaml.safe_load(made.block_yaml("ctrl"))
        scenario = yaml.safe_load(MSD)
        scenario["components"] = {"msd": scenario["components"]["msd"], **block,
                                  "push": {"kind": "step", "parameters": {"time": 0.5,
                                                                          "height": 1.0}},
                                  "sum": {"kind": "sum"}}
        scenario["connections"] = ["msd.y -> ctrl.u", "ctrl.y -> sum.u1", "push.y -> sum.u2",
                                   "sum.y -> msd.u"]
        scenario["experiment"]["stop"] = 20.0
        scenario["record"] = {"signals": ["msd.y"]}
        y = np.asarray(twmr.simulate(twmr.load(yaml.safe_dump(scenario))).data["msd.y"])
        finals[method] = y[-1]
        # python-control's steady state of the same loop (force at the plant's input)
        loop = control.feedback(analytic_msd(), made.controller(), sign=1)
        finals[f"{method} predicted"] = float(np.real(control.dcgain(loop)))
    assert abs(finals["lqi"]) < 1e-6 and abs(finals["lqi predicted"]) < 1e-9
    assert finals["lqg"] == pytest.approx(finals["lqg predicted"], rel=1e-3)
    assert abs(finals["lqg"]) > 1e-3  # the steady error integral action removes
    with pytest.raises(CosimError, match="a weight is above 0"):
        design(model, "lqi", qi=0.0)


def test_bad_designs_are_refused(model) -> None:
    with pytest.raises(CosimError, match="give 2 discrete poles"):
        design(model, "place", poles=[0.9], observer_poles=[0.5, 0.5])
    with pytest.raises(CosimError, match="inside the unit circle"):
        design(model, "place", poles=[1.2, 0.9], observer_poles=[0.5, 0.5])
    with pytest.raises(CosimError, match="a weight is above 0"):
        design(model, "lqg", r=0.0)
    with pytest.raises(CosimError, match="not a method"):
        design(model, "hinf")


def test_the_command_writes_the_design(tmp_path) -> None:
    import json
    import subprocess
    import sys

    (tmp_path / "msd.yaml").write_text(MSD)
    done = subprocess.run(
        [sys.executable, "-m", "twmr.cli", "linearize", "msd.yaml", "--input", "msd.u",
         "--output", "msd.y", "--at", "1", "--design", "place", "--poles", "0.95,0.9",
         "--observer-poles", "0.6,0.5", "--out", "lin"], cwd=tmp_path, capture_output=True,
        text=True, timeout=240)
    assert done.returncode == 0, done.stderr
    plain = json.loads((tmp_path / "lin" / "design.json").read_text())
    assert sorted(z[0] for z in plain["closed_loop_poles"]) == pytest.approx(
        [0.5, 0.6, 0.9, 0.95], abs=1e-8)
    assert yaml.safe_load((tmp_path / "lin" / "controller.yaml").read_text())["place"][
        "kind"] == "state_space"
    assert "closed-loop poles" in done.stdout and "gain margin" in done.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "twmr.cli", "linearize", "msd.yaml", "--input", "msd.u",
         "--output", "msd.y", "--at", "1", "--design", "place", "--poles", "0.9,x",
         "--observer-poles", "0.6,0.5", "--out", "lin"], cwd=tmp_path, capture_output=True,
        text=True, timeout=240)
    assert bad.returncode != 0 and "--poles '0.9,x': not a list of numbers" in bad.stderr
    assert "Traceback" not in bad.stderr
