"""`twmr linearize` / `twmr.linearize`: the linear model of a scenario around a point, against
models computed apart with python-control — a mass-spring-damper `state_space` block gives the
poles and impulse response of its zero-order-hold discretisation (`control.c2d`), a unit delay
its pole at 0, a loop broken at a wire the margins python-control gives for k G(z) / z — and bad
input refused."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import control
import numpy as np
import pytest

import twmr
from twmr.core.errors import CosimError
from twmr.linear_analysis import loop_at, source_of

pytestmark = pytest.mark.timeout(300)

M, C_DAMP, K_SPRING, H = 2.0, 0.8, 50.0, 0.01
MSD = f"""components:
  f: {{kind: constant, parameters: {{value: 1.0}}}}
  msd:
    kind: state_space
    parameters: {{A: [[0, 1], [{-K_SPRING / M}, {-C_DAMP / M}]], B: [0, {1 / M}], C: [1, 0]}}
connections: [f.y -> msd.u]
experiment: {{stop: 5.0, step: {H}}}
"""
LOOP = f"""components:
  r: {{kind: constant, parameters: {{value: 1.0}}}}
  e: {{kind: sum, parameters: {{signs: '+-'}}}}
  k: {{kind: gain, parameters: {{k: 3.0}}}}
  z: {{kind: delay}}
  plant: {{kind: first_order, parameters: {{K: 2.0, T: 0.5}}}}
connections: [r.y -> e.u1, plant.y -> e.u2, e.y -> k.u, k.y -> z.u, z.y -> plant.u]
experiment: {{stop: 5.0, step: {H}}}
"""


def analytic_msd() -> control.StateSpace:
    a = np.array([[0.0, 1.0], [-K_SPRING / M, -C_DAMP / M]])
    return control.c2d(control.ss(a, [[0.0], [1 / M]], [[1.0, 0.0]], [[0.0]]), H, "zoh")


def markov_of(sys: control.StateSpace, n: int) -> np.ndarray:
    out, x = [np.asarray(sys.D)], np.asarray(sys.B)
    for _ in range(n):
        out.append(np.asarray(sys.C) @ x)
        x = np.asarray(sys.A) @ x
    return np.array(out)


def test_a_mass_spring_damper_gives_its_zoh_model() -> None:
    model = twmr.linearize(twmr.load(MSD), ["msd.u"], ["msd.y"], at=1.0, horizon=60)
    ref = analytic_msd()
    assert model.order == 2 and model.fit_error < 1e-8 and model.nonlinearity < 1e-6
    assert np.sort_complex(model.poles()) == pytest.approx(np.sort_complex(ref.poles()),
                                                           abs=1e-9)
    np.testing.assert_allclose(markov_of(model.ss(), 60)[:, 0, 0],
                               markov_of(ref, 60)[:, 0, 0], atol=1e-10)
    a, b, c, d = model.continuous()
    assert np.sort_complex(np.linalg.eigvals(a)) == pytest.approx(
        np.sort_complex(np.roots([1.0, C_DAMP / M, K_SPRING / M])), abs=1e-6)
    dc = (c @ np.linalg.solve(-a, b) + d)[0, 0]
    assert dc == pytest.approx(1 / K_SPRING, rel=1e-6)


def test_zeros_ranks_and_step_figures_are_python_controls_of_the_exact_model() -> None:
    """The mass-spring-damper measured at its ports: the ZOH model's sampling zero, full
    controllability and observability, and the step response's rise, settling and overshoot
    as python-control computes them on c2d of the same matrices."""
    model = twmr.linearize(twmr.load(MSD), ["msd.u"], ["msd.y"], at=1.0, horizon=60)
    ref = analytic_msd()
    found = model.analysis()
    zeros = [complex(re, im) for re, im in found["zeros"]]
    assert zeros == pytest.approx(list(np.sort_complex(ref.zeros())), abs=1e-6)
    assert zeros[0].real < -0.9  # the sampling zero of a ZOH second-order system, near -1
    assert found["controllability"]["rank"] == found["observability"]["rank"] == 2
    step, expected = found["step"][0][0], control.step_info(ref)
    for key in ("RiseTime", "SettlingTime", "PeakTime"):
        assert step[key] == pytest.approx(expected[key], abs=H)
    for key in ("Overshoot", "SteadyStateValue", "Peak"):
        assert step[key] == pytest.approx(expected[key], rel=1e-6)


def test_a_dc_motor_exported_as_a_c_fmu_gives_its_analytic_model(tmp_path: Path) -> None:
    """A DC motor, L di/dt = V - R i - k w, J dw/dt = k i - b w, as a `state_space` block
    exported by twmr as a standalone C FMU (co-simulation) and run through fmpy: linearised at
    its ports, the ZOH model of python-control's c2d (poles 1e-9, impulse response 1e-10) and,
    converted back, the analytic continuous poles and the static gain k / (R b + k^2)."""
    from twmr.fmi.cexport import export_c_fmu

    r_ohm, l_h, k_t, j_kgm2, b_nms = 1.0, 0.5, 0.01, 0.01, 0.1
    a = [[-r_ohm / l_h, -k_t / l_h], [k_t / j_kgm2, -b_nms / j_kgm2]]
    fmu = export_c_fmu("state_space", tmp_path / "motor.fmu",
                       {"A": a, "B": [1 / l_h, 0.0], "C": [0.0, 1.0]})
    scenario = f"""components:
  v: {{kind: constant, parameters: {{value: 1.0}}}}
  motor: {{kind: fmu, parameters: {{path: {fmu}}}}}
connections: [v.y -> motor.u]
experiment: {{stop: 2.0, step: {H}}}
"""
    model = twmr.linearize(twmr.load(scenario), ["motor.u"], ["motor.y"], at=0.5, horizon=80)
    ref = control.c2d(control.ss(a, [[1 / l_h], [0.0]], [[0.0, 1.0]], [[0.0]]), H, "zoh")
    assert model.order == 2 and model.fit_error < 1e-8
    assert np.sort_complex(model.poles()) == pytest.approx(np.sort_complex(ref.poles()),
                                                           abs=1e-9)
    np.testing.assert_allclose(markov_of(model.ss(), 80)[:, 0, 0],
                               markov_of(ref, 80)[:, 0, 0], atol=1e-10)
    ca, cb, cc, cd = model.continuous()
    assert np.sort_complex(np.linalg.eigvals(ca)) == pytest.approx(
        np.sort_complex(np.linalg.eigvals(np.array(a))), rel=1e-6)
    gain = (cc @ np.linalg.solve(-ca, cb) + cd)[0, 0]
    assert gain == pytest.approx(k_t / (r_ohm * b_nms + k_t ** 2), rel=1e-6)


def test_a_unit_delay_has_its_pole_at_zero_and_no_continuous_twin() -> None:
    scenario = twmr.load("""components:
  f: {kind: constant}
  z: {kind: delay}
connections: [f.y -> z.u]
experiment: {stop: 1.0, step: 0.01}
""")
    model = twmr.linearize(scenario, ["z.u"], ["z.y"], at=0.2, horizon=20)
    assert model.order == 1 and abs(model.poles()[0]) < 1e-9
    np.testing.assert_allclose(model.markov[:4, 0, 0], [0.0, 1.0, 0.0, 0.0], atol=1e-12)
    with pytest.raises(CosimError, match="no continuous"):
        model.continuous()


def test_the_margins_of_a_loop_broken_at_a_wire_are_python_controls() -> None:
    """k G(z) / z: the gain, the plant's zero-order-hold model, the unit delay."""
    model = twmr.linearize(twmr.load(LOOP), ["plant.u"], ["z.y"], at=2.0, horizon=80)
    a = np.exp(-H / 0.5)
    analytic = 3.0 * control.tf([2.0 * (1 - a)], [1.0, -a, 0.0], H)
    got, want = control.margin(loop_at(model)), control.margin(analytic)
    assert all(np.isfinite(want))
    np.testing.assert_allclose(got, want, rtol=1e-6)


VECTOR_LOOP = f"""components:
  r: {{kind: constant, parameters: {{value: 1.0}}}}
  e: {{kind: sum, parameters: {{n: 2, signs: '+-'}}}}
  k: {{kind: gain, parameters: {{n_in: 2, n_out: 2, K: [[3.0, 0.0], [0.0, 1.5]]}}}}
  z: {{kind: delay}}
  z2: {{kind: delay}}
  plant: {{kind: first_order, parameters: {{K: 2.0, T: 0.5}}}}
  plant2: {{kind: first_order, parameters: {{K: 1.0, T: 0.2}}}}
connections: ["r.y -> e.u1[1]", "r.y -> e.u1[2]", "plant.y -> e.u2[1]", "plant2.y -> e.u2[2]",
              e.y -> k.u, "k.y[1] -> z.u", "k.y[2] -> z2.u", z.y -> plant.u, z2.y -> plant2.u]
experiment: {{stop: 5.0, step: {H}}}
"""


def test_a_loop_broken_at_one_element_of_a_vector_wire_is_that_channels() -> None:
    """Two decoupled loops behind one 2x2 gain: the loop broken at element 1 of the gain's
    input (fed by element 1 of the error) has the margins of 3 G1(z) / z, the one at element
    2 those of 1.5 G2(z) / z; the perturbation enters that element alone (a fault on one
    element of the port)."""
    scenario = twmr.load(VECTOR_LOOP)
    assert source_of(scenario, "k.u[2]") == "e.y[2]"
    for element, gain, tau, k_plant in ((1, 3.0, 0.5, 2.0), (2, 1.5, 0.2, 1.0)):
        model = twmr.linearize(scenario, [f"k.u[{element}]"], [f"e.y[{element}]"], at=2.0,
                               horizon=80)
        assert model.outputs == [f"e.y[{element}]"]
        a = np.exp(-H / tau)
        analytic = gain * control.tf([k_plant * (1 - a)], [1.0, -a, 0.0], H)
        np.testing.assert_allclose(control.margin(loop_at(model)), control.margin(analytic),
                                   rtol=1e-6)
    with pytest.raises(CosimError, match=r"has 2 elements: an input is perturbed one element"):
        twmr.linearize(scenario, ["k.u"], ["e.y[1]"], at=2.0, horizon=20)
    with pytest.raises(CosimError, match=r"give k.u\[1\] to k.u\[2\]"):
        twmr.linearize(scenario, ["k.u[3]"], ["e.y[1]"], at=2.0, horizon=20)


def test_the_nyquist_curve_of_a_loop_is_the_closed_form(tmp_path: Path) -> None:
    """The Nyquist curve drawn for k G(z) / z is L(e^{jωh}) of the closed form at its
    frequencies, from 0 (the static gain k K) to the Nyquist frequency."""
    from twmr.linear_analysis import nyquist_figure

    model = twmr.linearize(twmr.load(LOOP), ["plant.u"], ["z.y"], at=2.0, horizon=80)
    files, points = nyquist_figure(loop_at(model), H, tmp_path / "nyquist")
    a = np.exp(-H / 0.5)
    w = np.concatenate([[0.0], np.logspace(np.log10(np.pi / H) - 5, np.log10(np.pi / H), 2000)])
    z = np.exp(1j * w * H)
    want = 3.0 * 2.0 * (1 - a) / ((z - a) * z)
    np.testing.assert_allclose(points, want, rtol=1e-6, atol=1e-9)
    assert points[0] == pytest.approx(6.0, rel=1e-6)  # k K at ω = 0
    assert all(f.stat().st_size > 0 for f in files)


def test_the_command_writes_the_model_and_bad_input_is_refused(tmp_path: Path) -> None:
    (tmp_path / "loop.yaml").write_text(LOOP)
    done = subprocess.run([str(Path(sys.executable).parent / "twmr"), "linearize",
                           str(tmp_path / "loop.yaml"), "--loop", "plant.u", "--at", "2.0",
                           "--out", str(tmp_path / "lin")], capture_output=True, text=True,
                          timeout=200)
    assert done.returncode == 0, done.stderr
    assert "gain margin" in done.stdout
    for name in ("linear.json", "linear.npz", "state_space.yaml", "bode.png", "nyquist.png"):
        assert (tmp_path / "lin" / name).stat().st_size > 0, name
    block = [line for line in (tmp_path / "lin" / "state_space.yaml").read_text().splitlines()
             if not line.startswith("#")]
    back = twmr.load("components:\n" + "\n".join("  " + line for line in block) +
                     "\nopen: [lin.u]\nexperiment: {stop: 0.1, step: 0.01}\n")
    assert back.system.components["lin"].kind == "state_space"
    again = subprocess.run([str(Path(sys.executable).parent / "twmr"), "analyze",
                            str(tmp_path / "lin"), "--out", str(tmp_path / "figures")],
                           capture_output=True, text=True, timeout=200)
    assert again.returncode == 0, again.stderr
    margins = [line for line in done.stdout.splitlines() if "gain margin" in line]
    assert margins and margins[0].split(":", 1)[1] in again.stdout  # the same loop's margins
    assert "controllable: rank" in again.stdout and "zeros z:" in again.stdout
    for name in ("bode.png", "nyquist.png", "step.png"):
        assert (tmp_path / "figures" / name).stat().st_size > 1000, name
    missing = subprocess.run([str(Path(sys.executable).parent / "twmr"), "analyze",
                              str(tmp_path / "nowhere")], capture_output=True, text=True,
                             timeout=200)
    assert missing.returncode == 1 and "holds no model twmr linearize wrote" in missing.stderr
    assert "Traceback" not in missing.stderr
    saved = json.loads((tmp_path / "lin" / "linear.json").read_text())
    saved["B"] = [[1.0, 2.0]] * len(saved["A"])  # two inputs' columns for one input
    (tmp_path / "lin" / "linear.json").write_text(json.dumps(saved))
    bent = subprocess.run([str(Path(sys.executable).parent / "twmr"), "analyze",
                           str(tmp_path / "lin")], capture_output=True, text=True, timeout=200)
    assert bent.returncode == 1 and "B is" in bent.stderr and "x 1 finite numbers" in bent.stderr
    assert "Traceback" not in bent.stderr
    kink = """components:
  c: {kind: constant, parameters: {value: 1.0}}
  g: {kind: gain, parameters: {k: 1.0}}
  sat: {kind: saturation, parameters: {upper: 1.0, lower: -1.0}}
  f: {kind: first_order, parameters: {K: 1.0, T: 0.1}}
connections: [c.y -> g.u, g.y -> sat.u, sat.y -> f.u]
experiment: {stop: 2, step: 0.01}
"""
    with pytest.raises(CosimError, match=r"f\.y responds to pulses of \+0\.001 and -0\.001 at "
                                         r"g\.u \(t = 1 s\) unequally: .* reaches 1 of .*kink"):
        twmr.linearize(twmr.load(kink), ["g.u"], ["f.y"], at=1.0)  # on the saturation's edge
    inside = twmr.linearize(twmr.load(kink, ["c.value=0.5"]), ["g.u"], ["f.y"], at=1.0)
    assert inside.order == 1 and inside.nonlinearity < 1e-9
    msd = twmr.load(MSD)
    with pytest.raises(CosimError, match="names no port"):
        twmr.linearize(msd, ["msd.v"], ["msd.y"], at=1.0)
    with pytest.raises(CosimError, match="not a communication point"):
        twmr.linearize(msd, ["msd.u"], ["msd.y"], at=1.005)


def test_the_steady_point_is_found_and_linearised_there() -> None:
    """--at steady: the mass-spring-damper under a constant force settles at x = F / k; the
    point found is where its output stops moving, and the model there is the ZOH model."""
    from twmr.linear_analysis import steady_time

    scenario = twmr.load(MSD, ["experiment.stop=120", "f.value=2.0"])
    t = steady_time(scenario, ["msd.y"])
    # the slowest mode decays as exp(-c t / 2 m); the step's change falls below 1e-9 after
    # about log(amplitude * w h / 1e-9) / (c / 2 m) s
    envelope = 2.0 / K_SPRING * np.sqrt(K_SPRING / M) * H
    assert t == pytest.approx(np.log(envelope / 1e-9) / (C_DAMP / (2 * M)), rel=0.1)
    run = twmr.simulate(twmr.load(MSD, ["experiment.stop=120", "f.value=2.0"]), None)
    y = np.asarray(run["msd.y"])[np.asarray(run["time"]) >= t - 1e-9]
    assert np.abs(y - 2.0 / K_SPRING).max() < 1e-7
    model = twmr.linearize(scenario, ["msd.u"], ["msd.y"], at="steady", horizon=60)
    assert model.at == pytest.approx(t)
    assert np.sort_complex(model.poles()) == pytest.approx(
        np.sort_complex(analytic_msd().poles()), abs=1e-9)


def test_a_run_that_does_not_settle_is_refused_naming_the_output() -> None:
    with pytest.raises(CosimError, match=r"does not settle by its stop \(5 s\): msd.y still "
                                         r"changes .* Fix: a later experiment.stop"):
        twmr.linearize(twmr.load(MSD), ["msd.u"], ["msd.y"], at="steady")
    with pytest.raises(CosimError, match=r"at = 'soon' is no point"):
        twmr.linearize(twmr.load(MSD), ["msd.u"], ["msd.y"], at="soon")
