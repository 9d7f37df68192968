"""Trim points solved for (`twmr.linear_trim.trim`, `twmr linearize --trim`): an inverted
pendulum built from blocks, theta'' = (g/l) sin(theta) - c theta' + f, is trimmed at its upright,
unstable equilibrium theta* = -asin(f l / g) (which no run settles at) and linearised there: one
pole outside the unit circle, both within 1 % of the analytic continuous poles (the
co-simulation is the ODE's discretisation at h = 1 ms: O(h) apart); the Reference FMU
VanDerPol, started off its unstable focus, is trimmed to the origin, where its directional
derivatives give A = [[0, 1], [-1, mu]] (FMI 2.0 and 3.0). Bad input is refused naming the
value or the output."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conformance.corpus import corpus
from twmr.core.errors import CosimError
from twmr.linear_analysis import linearize, linearize_fmu
from twmr.linear_trim import trim

pytestmark = pytest.mark.timeout(300)

G, C, F = 9.81, 0.5, 1.0
PENDULUM = f"""
components:
  push: {{kind: constant, parameters: {{value: {F}}}}}
  u: {{kind: gain, parameters: {{k: 1.0}}}}
  w: {{kind: integrator, parameters: {{x0: 0.1}}}}
  th: {{kind: integrator, parameters: {{x0: 0.3}}}}
  s: {{kind: math, parameters: {{function: sin}}}}
  g: {{kind: gain, parameters: {{k: {G}}}}}
  c: {{kind: gain, parameters: {{k: {-C}}}}}
  acc: {{kind: sum, parameters: {{signs: "+++"}}}}
  spare: {{kind: constant, parameters: {{value: 2.0}}}}
connections:
  - push.y -> u.u
  - th.y -> s.u
  - s.y -> g.u
  - w.y -> c.u
  - g.y -> acc.u1
  - c.y -> acc.u2
  - u.y -> acc.u3
  - acc.y -> w.u
  - w.y -> th.u
experiment: {{start: 0, stop: 1, step: 0.001}}
"""
THETA = -math.asin(F / G)


def test_the_upright_pendulum_is_trimmed_and_linearised_there() -> None:
    point = trim(PENDULUM, ["th.x0", "w.x0"])
    assert point.values["th.x0"] == pytest.approx(THETA, abs=1e-9)
    assert abs(point.values["w.x0"]) < 1e-9
    assert point.change <= 1e-12 and point.iterations <= 10
    model = linearize(PENDULUM, ["u.u"], ["th.y"], at=0.0, horizon=60, amplitude=1e-5,
                      overrides=point.overrides)
    assert model.order == 2 and model.fit_error < 1e-6
    z = np.sort(np.linalg.eigvals(model.A).real)
    assert z[1] > 1.0 > z[0] > 0.0  # one unstable pole: the upright equilibrium
    analytic = np.sort(np.roots([1.0, C, -G * math.cos(THETA)]))
    np.testing.assert_allclose(np.log(z) / 0.001, analytic, rtol=0.01)
    # the same poles by finite differences through the start values (the states set)
    assert point.step_matrix is not None and point.step_matrix_error < 1e-6
    np.testing.assert_allclose(np.sort(point.poles().real), z, rtol=1e-6)  # as the step map


def test_more_unknowns_than_needed_give_one_point_of_the_family() -> None:
    point = trim(PENDULUM, ["th.x0", "w.x0", "push.value"])
    theta, f = point.values["th.x0"], point.values["push.value"]
    assert G * math.sin(theta) + f == pytest.approx(0.0, abs=1e-9)  # an equilibrium
    assert abs(point.values["w.x0"]) < 1e-9


def test_the_step_map_by_finite_differences_is_rk4s_of_the_jacobian() -> None:
    """VanDerPol under RK4 (one substep per step of h): its step map near the origin is RK4's
    polynomial of A h, A = [[0, 1], [-1, mu]] (the FMU's own directional derivatives), which
    the finite differences through the start values give to 1e-8."""
    path = corpus("reference-fmus", "VanDerPol_fmi2.fmu")
    h = 0.01
    scenario = {"components": {"vdp": {"kind": "fmu", "parameters": {
        "path": str(path), "interface": "model_exchange", "solver": "rk4",
        "solver_step": h}}}, "experiment": {"stop": 1.0, "step": h}}
    point = trim(scenario, ["vdp.x0", "vdp.x1"], overrides=["vdp.x0=0.3", "vdp.x1=-0.2"])
    jac = linearize_fmu(scenario, "vdp", at=0.0, overrides=point.overrides).A
    np.testing.assert_allclose(jac, [[0.0, 1.0], [-1.0, 1.0]], atol=1e-8)
    ah = jac * h
    rk4 = np.eye(2) + ah + ah @ ah / 2 + ah @ ah @ ah / 6 + ah @ ah @ ah @ ah / 24
    assert point.step_matrix is not None
    np.testing.assert_allclose(point.step_matrix, rk4, atol=1e-8)
    assert point.step_matrix_error < 1e-6


@pytest.mark.parametrize("name", ["VanDerPol_fmi2.fmu", "VanDerPol_fmi3.fmu"])
def test_vanderpol_is_trimmed_to_its_unstable_focus(name: str) -> None:
    path = corpus("reference-fmus", name)
    scenario = {"components": {"vdp": {"kind": "fmu", "parameters": {
        "path": str(path), "interface": "model_exchange"}}},
        "experiment": {"stop": 1.0, "step": 0.01}}
    point = trim(scenario, ["vdp.x0", "vdp.x1"], overrides=["vdp.x0=0.3", "vdp.x1=-0.2"])
    assert abs(point.values["vdp.x0"]) < 1e-9 and abs(point.values["vdp.x1"]) < 1e-9
    model = linearize_fmu(scenario, "vdp", at=0.0, overrides=point.overrides)
    np.testing.assert_allclose(model.A, [[0.0, 1.0], [-1.0, 1.0]], atol=1e-8)
    assert np.all(np.linalg.eigvals(model.A).real > 0)  # unstable: no run settles there


SQRT = """components:
  x: {kind: integrator, parameters: {x0: 16.0}}
  s: {kind: math, parameters: {function: sqrt}}
  g: {kind: gain, parameters: {k: -1.0}}
  c: {kind: constant, parameters: {value: 1.5}}
  sum: {kind: sum, parameters: {signs: "++"}}
connections: [x.y -> s.u, s.y -> g.u, g.y -> sum.u1, c.y -> sum.u2, sum.y -> x.u]
experiment: {stop: 1, step: 0.01}
"""


def test_a_newton_step_the_scenario_cannot_run_at_is_shortened() -> None:
    """x' = 1.5 - sqrt(x) from x = 16: the first Newton step lands at x = -4, where sqrt gives
    NaN and the run stops; the step is halved until it runs, and x* = 2.25 is reached. Started
    at x = -1, where nothing runs, the trim is refused naming the value; linearised at x = 0
    without a source, a pulse's run stops (sqrt of a negative), said as such."""
    point = trim(SQRT, ["x.x0"])
    assert point.values["x.x0"] == pytest.approx(2.25, abs=1e-9)
    with pytest.raises(CosimError, match=r"trim: the one-step run with x\.x0=-1\.0 failed: "
                                         r"component 's' .* 'y' is nan.*Fix: start where"):
        trim(SQRT, ["x.x0"], overrides=["x.x0=-1"])
    with pytest.raises(CosimError, match=r"linearize: the run with a pulse of [+-]0\.001 "
                                         r"at sum\.u2 at t = 0 s, on to 2 s \(the horizon\), "
                                         r"failed: .*nan"):
        linearize(SQRT, ["sum.u2"], ["x.y"], at=0.0, overrides=["x.x0=0", "c.value=0"])


def test_what_cannot_be_trimmed_is_refused() -> None:
    with pytest.raises(CosimError, match=r"'th\.x00' names no value.*did you mean 'x0'"):
        trim(PENDULUM, ["th.x00"])
    with pytest.raises(CosimError, match=r"spare\.value moves none of the outputs checked "
                                         r"\(th\.y\).*Fix:"):
        trim(PENDULUM, ["spare.value"], outputs=["th.y"])
    with pytest.raises(CosimError, match=r"no steady point reached in 3 Newton iterations: "
                                         r"\w+\.y still changes by .*Fix:"):
        trim(PENDULUM, ["push.value"], max_iter=3)
    with pytest.raises(CosimError, match=r"'th\.yy' names no real output.*did you mean 'y'"):
        trim(PENDULUM, ["th.x0"], outputs=["th.yy"])
    with pytest.raises(CosimError, match=r"'th\.y' is a Real output, not a real value a run "
                                         r"starts from"):
        trim(PENDULUM, ["th.y"])
    with pytest.raises(CosimError, match="at least one unknown"):
        trim(PENDULUM, [])


def test_the_command_trims_then_linearises(tmp_path: Path) -> None:
    (tmp_path / "pend.yaml").write_text(PENDULUM)
    command = [sys.executable, "-m", "twmr.cli", "linearize", "pend.yaml", "--input", "u.u",
               "--output", "th.y", "--horizon", "60", "--amplitude", "1e-5", "--out", "lin"]
    done = subprocess.run([*command, "--trim", "th.x0,w.x0"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=200)
    assert done.returncode == 0, done.stderr
    assert "trim point (" in done.stdout and "th.x0=-0.10211416" in done.stdout
    saved = json.loads((tmp_path / "lin" / "linear.json").read_text())
    assert saved["trim"]["values"]["th.x0"] == pytest.approx(THETA, abs=1e-9)
    assert saved["order"] == 2 and saved["at"] == 0.0
    both = subprocess.run([*command, "--trim", "th.x0", "--at", "0.5"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=200)
    neither = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True,
                             timeout=200)
    assert both.returncode == 1 and "give it without --at" in both.stderr
    assert neither.returncode == 1 and "--trim COMP.STATE" in neither.stderr
    assert "Traceback" not in both.stderr + neither.stderr


def test_hardware_and_wall_clock_runs_are_not_replayed() -> None:
    """linearize and trim run a scenario many times from its start: a drive on a CAN bus (here
    the emulated bench of the paper's robot) or a run paced to the wall clock is refused,
    naming it, before anything runs."""
    bench = Path(__file__).resolve().parents[2] / "scenarios" / "bench_odrive_trajectory1.yaml"
    with pytest.raises(CosimError, match=r"component 'motor' is hardware in the loop.*Fix:"):
        linearize(bench, ["plant.torque[1]"], ["plant.pose"], at=1.0)
    with pytest.raises(CosimError, match=r"trim runs the scenario many times.*hardware"):
        trim(bench, ["plant.pose"])
    with pytest.raises(CosimError, match=r"paced to the wall clock.*realtime: false"):
        trim(PENDULUM, ["th.x0"], overrides=["experiment.realtime=true"])
