"""FMU import as the FMI standard says, with FMUs built from tests/fmus: a Boolean structural
parameter (roberts3, like the Modelica Association's Roberts) is a parameter, not a size; aliases
(FMI 3.0 `<Alias>`, FMI 2.0 shared value references) are one variable, read only under their
other names and shown in their own display unit; state support follows the model description
per interface, and a model-exchange step re-run after a restore repeats the first bit for bit.
Checked against the analytic ball, scipy's Radau and fmpy's simulate_fmu."""
from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from fmpy import simulate_fmu
from scipy.integrate import solve_ivp

from tests.fmu_build import build_c_fmu
from twmr.core import FmuError, ScenarioError
from twmr.core.units import conversion
from twmr.fmi import describe_fmu
from twmr.fmi.fmu import FmuComponent
from twmr.master import simulate
from twmr.master.algorithm import admit
from twmr.master.schedule import FixedStep
from twmr.scenario import loads
from twmr.scenario.listing import describe

G, E = 9.81, 0.7
#: feet per metre, the factor of bounce3's DisplayUnit "ft"
FT = 3.28084


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, str]:
    out = tmp_path_factory.mktemp("conformance")
    built = {n: str(build_c_fmu(n, out)) for n in ("bounce2", "discin2")}
    built.update({n: str(build_c_fmu(n, out, fmi3=True)) for n in ("bounce3", "roberts3",
                                                                     "types3")})
    return built


def scenario(path: str, settings: str = "", initial: str = "", stop: float = 1.0,
             step: float = 0.01) -> str:
    return f"""
components:
  ball: {{kind: fmu, parameters: {{path: {path}{settings}}}, initial: {{{initial}}}}}
experiment: {{start: 0.0, stop: {stop}, step: {step}}}
"""


def free_fall(t: np.ndarray, h0: float) -> np.ndarray:
    """Height [m] of the ball dropped from h0 at rest, up to its first bounce."""
    return h0 - G / 2 * t**2


# ---- aliases ------------------------------------------------------------------------------

@pytest.mark.parametrize("settings", [", interface: co_simulation",
                                      ", interface: model_exchange, rtol: 1.0e-10",
                                      ", isolate: true"])
def test_fmi3_alias_is_the_same_variable_read_in_its_own_display_unit(fmus, settings) -> None:
    ball = FmuComponent("ball", fmus["bounce3"])
    alias = ball.variables["h_ft"]
    assert alias.kind == "output" and alias.unit == "ft" and alias.depends_on == ()
    gain, offset = conversion(alias.unit_definitions["ft"], "m")
    assert gain == pytest.approx(1 / FT, rel=1e-15) and offset == 0.0
    assert ball.aliases == {"h_ft": "h", "gravity": "g"}
    r = simulate(loads(scenario(fmus["bounce3"], settings, "h: 2.0", stop=0.6), source="b.yaml"))
    t = np.asarray(r["time"])
    assert math.sqrt(2 * 2.0 / G) > t[-1]  # no bounce yet: free fall from 2 m
    np.testing.assert_allclose(r["ball.h"], free_fall(t, 2.0), rtol=0, atol=1e-8)
    np.testing.assert_allclose(r["ball.h_ft"], FT * free_fall(t, 2.0), rtol=0, atol=FT * 1e-8)
    # fmpy reads the alias as the FMU gives it: the base variable's value, in metres
    ref = simulate_fmu(fmus["bounce3"], stop_time=0.6, output_interval=0.01,
                       fmi_type="CoSimulation", start_values={"h": 2.0}, output=["h", "h_ft"])
    assert np.array_equal(ref["h_ft"], ref["h"])
    np.testing.assert_allclose(r["ball.h_ft"], FT * ref["h"], rtol=0, atol=FT * 1e-8)


@pytest.mark.parametrize("initial, message", [
    ("h: 2.0, h_ft: 3.0", "'h_ft' is an alias of 'h' ('h' is set as well)"),
    ("h_ft: 3.0", "'h_ft' is an alias of 'h': one variable of the FMU")])
def test_setting_an_alias_is_refused_at_check_naming_its_base(fmus, initial, message) -> None:
    with pytest.raises(ScenarioError) as err:
        loads(scenario(fmus["bounce3"], initial=initial), source="b.yaml")
    text = str(err.value)
    assert "b.yaml:3" in text and message in text and "Fix: set 'h' only" in text


def test_an_alias_of_a_parameter_is_no_port_and_is_refused(fmus) -> None:
    assert "gravity" not in FmuComponent("ball", fmus["bounce3"]).variables
    with pytest.raises(ScenarioError, match=r"'gravity' is an alias of 'g'.*Fix: set 'g' only"):
        loads(scenario(fmus["bounce3"], ", gravity: 3.0"), source="b.yaml")
    with pytest.raises(ValueError, match="'h_ft' is an alias of 'h'"):
        FmuComponent("ball", fmus["bounce3"], h_ft=3.0)
    wired = scenario(fmus["bounce3"]) + "connections:\n  - ball.h -> ball.gravity\n"
    with pytest.raises(ScenarioError, match=r"'ball.gravity' is an alias of parameter 'ball.g' "
                                            r".*Fix: set 'g' under 'parameters:'"):
        loads(wired, source="b.yaml")
    text = describe_fmu(fmus["bounce3"])
    assert "output    h_ft [ft] Real (Float64) = 3.28084 (alias of h, read only)" in text
    assert "aliases (other names of a port, never set): h_ft = h, gravity = g" in text


def test_fmi2_variables_sharing_a_value_reference_are_one_variable(fmus) -> None:
    ball = FmuComponent("ball", fmus["bounce2"])
    assert ball.aliases == {"height": "h", "restitution": "e"}
    assert ball.variables["height"].kind == "output" and ball.variables["height"].start == 1.0
    assert ball.variables["height"].depends_on == () and "restitution" not in ball.variables
    r = simulate(loads(scenario(fmus["bounce2"], initial="h: 2.0", stop=0.6), source="b.yaml"))
    np.testing.assert_allclose(r["ball.h"], free_fall(np.asarray(r["time"]), 2.0), atol=1e-8)
    assert np.array_equal(r["ball.height"], r["ball.h"])
    with pytest.raises(ScenarioError, match=r"'height' is an alias of 'h' \('h' is set as well"):
        loads(scenario(fmus["bounce2"], initial="h: 2.0, height: 3.0"), source="b.yaml")
    with pytest.raises(ScenarioError, match=r"'restitution' is an alias of 'e'"):
        loads(scenario(fmus["bounce2"], ", restitution: 0.5"), source="b.yaml")


# ---- a Boolean structural parameter (Roberts) --------------------------------------------

def robertson(t: float, y: np.ndarray) -> list[float]:
    y1, y2 = y
    y3 = 1.0 - y1 - y2
    return [-0.04 * y1 + 1e4 * y2 * y3, 0.04 * y1 - 1e4 * y2 * y3 - 3e7 * y2**2]


def test_a_boolean_structural_parameter_is_a_boolean_parameter(fmus) -> None:
    text = describe_fmu(fmus["roberts3"])
    assert "parameter dae [] Boolean = False" in text
    chem = FmuComponent("chem", fmus["roberts3"], dae=False)
    assert chem.variables["dae"].type == "Boolean" and chem.me


def test_roberts_runs_and_matches_scipy_and_fmpy(fmus) -> None:
    r = simulate(loads(scenario(fmus["roberts3"], ", rtol: 1.0e-8, dae: false", stop=40.0,
                                step=0.4), source="r.yaml"))
    t = np.asarray(r["time"])
    ref = solve_ivp(robertson, (0.0, 40.0), [1.0, 0.0], method="Radau", t_eval=t, rtol=1e-12,
                    atol=1e-16)
    np.testing.assert_allclose(r["ball.y1"], ref.y[0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(r["ball.y2"], ref.y[1], rtol=0, atol=1e-11)
    np.testing.assert_allclose(r["ball.y3"], 1 - ref.y[0] - ref.y[1], rtol=0, atol=1e-7)
    # Robertson's problem at t = 40 (Hairer & Wanner, Solving ODEs II)
    assert (ref.y[0][-1], ref.y[1][-1]) == (pytest.approx(0.7158271, abs=1e-7),
                                            pytest.approx(9.185535e-6, rel=1e-6))
    fm = simulate_fmu(fmus["roberts3"], stop_time=40.0, output_interval=0.4,
                      relative_tolerance=1e-8, output=["y1", "y2"])
    np.testing.assert_allclose(r["ball.y1"], fm["y1"], rtol=0, atol=2e-7)


def test_the_boolean_reaches_the_fmu_in_configuration_mode(fmus) -> None:
    with pytest.raises(FmuError) as err:
        simulate(loads(scenario(fmus["roberts3"], ", dae: true"), source="r.yaml"))
    text = str(err.value)
    assert "fmi3EnterInitializationMode failed" in text
    assert "dae = true (the semi-explicit DAE form) is not provided" in text


# ---- what `twmr check` shows ---------------------------------------------------------------

def test_check_shows_the_open_input_values_the_run_uses(fmus) -> None:
    text = f"""
components:
  t: {{kind: fmu, parameters: {{path: {fmus["types3"]}, n: 5}},
      initial: {{Float64_input: 7.5, vec_in: [4, 5, 6]}}}}
experiment: {{start: 0.0, stop: 0.02, step: 0.01}}
open: [t.Float64_input, t.vec_in]
"""
    with pytest.raises(ScenarioError, match=r"'t.vec_in' under 'open:' to keep its start "
                                            r"value \(4.0, 5.0, 6.0\)\."):
        loads(text.replace(", t.vec_in]", "]"), source="t.yaml")
    opened = ", ".join(f"t.{p}_input" for p in ("Float32", "Int8", "UInt8", "Int16", "UInt16",
                                                "Int32", "UInt32", "Int64", "UInt64", "Boolean",
                                                "String", "Binary", "Enumeration"))
    system = loads(text.replace("open: [", f"open: [{opened}, "), source="t.yaml")
    shown = describe(system)
    assert "t.Float64_input = 7.5" in shown and "t.vec_in = (4.0, 5.0, 6.0)" in shown
    r = simulate(system)
    assert list(r["t.Float64_output"]) == [7.5] * 3
    assert [tuple(r[f"t.vec_out[{i}]"]) for i in (1, 2, 3)] == [(8.0,) * 3, (10.0,) * 3,
                                                                  (12.0,) * 3]


# ---- FMU state ----------------------------------------------------------------------------

class Rollback(FixedStep):
    needs_state_rollback = True


def test_state_support_follows_the_description_per_interface(fmus) -> None:
    for interface in ("co_simulation", "model_exchange"):
        assert FmuComponent("b", fmus["bounce3"], interface=interface).can_get_and_set_state
        assert not FmuComponent("b", fmus["bounce2"], interface=interface).can_get_and_set_state
    admit(loads(scenario(fmus["bounce3"], ", interface: model_exchange")), Rollback("jacobi"))
    with pytest.raises(ScenarioError) as err:
        admit(loads(scenario(fmus["bounce2"], ", interface: model_exchange")),
              Rollback("jacobi"), "rollback")
    text = str(err.value)
    assert "'ball' (FmuComponent) cannot save and restore its state: its modelDescription.xml " \
           "does not declare canGetAndSetFMUstate=\"true\" for model exchange." in text


def steps(comp: FmuComponent, t0: float, n: int, h: float = 0.01) -> list[tuple]:
    rows = []
    for k in range(n):
        comp.do_step(t0 + k * h, h)
        rows.append((comp.h, comp.v, comp.bounces, comp.h_ft))
    return rows


@pytest.mark.parametrize("solver", [{"rtol": 1e-9}, {"solver": "rk4", "solver_step": 1e-3}])
def test_model_exchange_steps_rerun_after_a_restore_are_bit_identical(fmus, solver) -> None:
    """CVODE goes on after a save with its history (`repeats_steps` False) and restarts at every
    restore: the reruns equal one another bit for bit, and the first run to the tolerance; RK4
    keeps no history, so the first run is repeated too."""
    ball = FmuComponent("ball", fmus["bounce3"], interface="model_exchange", **solver)
    other = FmuComponent("ball", fmus["bounce3"], interface="model_exchange", **solver)
    for c in (ball, other):
        c.setup(0.0, None)
        c.initialize()
    try:
        steps(ball, 0.0, 40)
        saved = ball.get_state()
        assert isinstance(saved[0], bytes)  # serialised: it pickles and crosses processes
        first = steps(ball, 0.4, 30)  # across the first bounce, t1 = 0.4515 s
        assert first[0][2] == 0 and first[-1][2] == 1
        assert first[-1][0] == pytest.approx(E * math.sqrt(2 * G) * (0.7 - math.sqrt(2 / G))
                                             - G / 2 * (0.7 - math.sqrt(2 / G))**2, abs=1e-6)
        assert ball.repeats_steps() == ("solver" in solver)
        events = ball.report()["events"]
        ball.set_state(pickle.loads(pickle.dumps(saved)))
        rerun = steps(ball, 0.4, 30)
        assert np.allclose(rerun, first, rtol=0, atol=1e-6)
        assert (rerun == first) == ("solver" in solver)
        assert ball.report()["events"] == events  # the bounce undone is not counted twice
        ball.set_state(saved)
        assert steps(ball, 0.4, 30) == rerun
        other.set_state(saved)
        assert steps(other, 0.4, 30) == rerun
    finally:
        ball.terminate()
        other.terminate()


def test_a_step_whose_input_changed_at_its_start_repeats_from_a_save(fmus) -> None:
    """A continuous input changed after a save restarts CVODE there, so the step from the save
    does not depend on the history before it (`repeats_steps`); an unchanged one lets CVODE go
    on with its history."""
    comp = FmuComponent("d", fmus["discin2"], interface="model_exchange")
    comp.setup(0.0, None)
    comp.initialize()
    integ = comp._integrator
    try:
        for k, u in enumerate([1.0, 1.0, 1.0, 2.0, 2.0]):
            integ.save()  # as the adaptive master's get_state does (discin2 has no FMU state)
            comp.u = u
            comp.evaluate(k * 0.1)
            comp.do_step(k * 0.1, 0.1)
            assert comp.repeats_steps() == (k in (0, 3)), k
        assert comp.x == pytest.approx(0.3 + 0.4, abs=1e-6)
    finally:
        comp.terminate()
