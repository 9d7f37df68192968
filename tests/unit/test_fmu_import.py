"""FmuComponent over a C FMU built at test time: ports, units, feedthrough, results against the
analytic solution and against fmpy's own simulate_fmu; bad FMUs give FmuError."""
from __future__ import annotations

import math
import zipfile

import numpy as np
import pytest
from fmpy import simulate_fmu

from tests.fmu_build import build_c_fmu
from twmr.core import FmuError, ScenarioError
from twmr.fmi.fmu import FmuComponent
from twmr.master import simulate
from twmr.scenario import loads


@pytest.fixture(scope="session")
def lag2(tmp_path_factory) -> str:
    return str(build_c_fmu("lag2", tmp_path_factory.mktemp("fmus")))


def test_ports_units_and_feedthrough_from_model_description(lag2) -> None:
    c = FmuComponent("lag", lag2)
    assert c.variables["u"].size == 2 and c.variables["u"].unit == "m"
    assert c.variables["y"].kind == "state"  # an output with initial="exact": its start is settable
    assert c.variables["y"].depends_on == ()
    assert c.variables["T"].kind == "parameter" and c.variables["T"].unit == "s"
    assert c.T == 0.5 and c.k == 2.0
    assert not c.has_feedthrough


SCENARIO = """
components:
  src: {kind: constant, parameters: {value: 1.5}}
  lag:
    kind: fmu
    parameters: {path: %s, T: 0.25}
connections:
  - src.y -> lag.u[1]
  - src.y -> lag.u[2]
experiment: {start: 0.0, stop: 1.0, step: 0.01}
record: {signals: [lag.y]}
"""


def test_master_run_matches_the_analytic_solution(lag2) -> None:
    r = simulate(loads(SCENARIO % lag2, source="fmu.yaml"))
    expected = 2.0 * 1.5 * (1.0 - np.exp(-r["time"] / 0.25))
    np.testing.assert_allclose(r["lag.y[1]"], expected, atol=1e-12)
    np.testing.assert_allclose(r["lag.y[2]"], expected, atol=1e-12)


def test_master_run_matches_fmpy_simulate_fmu(lag2) -> None:
    r = simulate(loads(SCENARIO % lag2, source="fmu.yaml"))
    t = np.asarray(r["time"])
    signals = np.zeros(len(t), dtype=[("time", float), ("u[1]", float), ("u[2]", float)])
    signals["time"], signals["u[1]"], signals["u[2]"] = t, 1.5, 1.5
    ref = simulate_fmu(lag2, start_time=0.0, stop_time=1.0, output_interval=0.01,
                       start_values={"T": 0.25}, input=signals, output=["y[1]", "y[2]"])
    np.testing.assert_allclose(r["lag.y[1]"], ref["y[1]"], rtol=0, atol=1e-14)


def test_a_value_outside_the_fmus_min_is_refused_at_check(lag2) -> None:
    with pytest.raises(ScenarioError) as err:
        loads((SCENARIO % lag2).replace("T: 0.25", "T: -1.0"), source="fmu.yaml")
    assert "fmu.yaml:6" in str(err.value) and "below the minimum 1e-09" in str(err.value)


def test_fmi_error_status_names_instance_call_time_and_log(tmp_path) -> None:
    faulty = build_c_fmu("faulty", tmp_path)
    scenario = f"""
components:
  f: {{kind: fmu, parameters: {{path: {faulty}, mode: 4, fail_after: 3}}}}
open: [f.u]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
"""
    with pytest.raises(FmuError) as err:
        simulate(loads(scenario, source="fmu.yaml"))
    e = err.value
    assert e.instance == "f" and e.time == pytest.approx(0.2)  # the third doStep starts there
    assert "fmi2DoStep failed" in str(e) and "faulty.fmu" in str(e)
    assert e.log and "ERROR" in e.log[-1] and "FMU log (last lines)" in str(e)


def test_not_a_zip_and_missing_file(tmp_path) -> None:
    bad = tmp_path / "bad.fmu"
    bad.write_text("not a zip")
    with pytest.raises(FmuError, match="not a readable FMU"):
        FmuComponent("x", bad)
    with pytest.raises(FmuError, match="not found"):
        FmuComponent("x", tmp_path / "missing.fmu")
    empty = tmp_path / "empty.fmu"
    with zipfile.ZipFile(empty, "w") as z:
        z.writestr("readme.txt", "no model description")
    with pytest.raises(FmuError, match="not a readable FMU"):
        FmuComponent("x", empty)


def test_scenario_with_a_missing_fmu_is_a_located_error(tmp_path) -> None:
    with pytest.raises(ScenarioError) as err:
        loads(SCENARIO % "nowhere.fmu", source="fmu.yaml", base_dir=tmp_path)
    assert "fmu.yaml:6" in str(err.value) and "not found" in str(err.value)


def test_state_can_be_saved_and_restored(lag2) -> None:
    c = FmuComponent("lag", lag2)
    c.setup(0.0, 1.0)
    c.initialize()
    c.u = (1.0, 1.0)
    c.do_step(0.0, 0.1)
    saved = c.get_state()
    c.do_step(0.1, 0.1)
    after = c.y
    c.set_state(saved)
    c.do_step(0.1, 0.1)
    assert c.y == after
    c.terminate()
    assert math.isfinite(after[0])


@pytest.fixture(scope="session")
def lag3(tmp_path_factory) -> str:
    return str(build_c_fmu("lag3", tmp_path_factory.mktemp("fmus3"), fmi3=True))


def test_fmi3_fmu_runs_and_matches_fmpy(lag3) -> None:
    c = FmuComponent("lag", lag3)
    assert c.fmi3 and c.variables["u"].size == 2 and c.variables["T"].unit == "s"
    r = simulate(loads(SCENARIO % lag3, source="fmu3.yaml"))
    expected = 2.0 * 1.5 * (1.0 - np.exp(-r["time"] / 0.25))
    np.testing.assert_allclose(r["lag.y[1]"], expected, atol=1e-12)
    t = np.asarray(r["time"])
    signals = np.zeros(len(t), dtype=[("time", float), ("u[1]", float), ("u[2]", float)])
    signals["time"], signals["u[1]"], signals["u[2]"] = t, 1.5, 1.5
    ref = simulate_fmu(lag3, start_time=0.0, stop_time=1.0, output_interval=0.01,
                       start_values={"T": 0.25}, input=signals, output=["y[2]"])
    np.testing.assert_allclose(r["lag.y[2]"], ref["y[2]"], rtol=0, atol=1e-14)


def test_inspect_describes_ports_platform_and_usage(lag2, lag3) -> None:
    from twmr.fmi import describe_fmu

    text = describe_fmu(lag2)
    assert "FMI 2.0 (co-simulation, model exchange)" in text and "can run it" in text
    assert "input     u[2] [m] Real" in text and "parameter T [s]" in text
    assert "FMI 3.0" in describe_fmu(lag3)


@pytest.mark.parametrize("solver, bound", [("solver: rk4, solver_step: 0.01", 1e-7),
                                           ("rtol: 1.0e-10", 1e-8), ("rtol: 1.0e-4", 1e-3)])
def test_model_exchange_interface_is_integrated(lag2, solver, bound) -> None:
    """The same FMU through its model-exchange interface: RK4 error ~ (h/T)^5 per step; CVODE's
    error follows its tolerance."""
    text = (SCENARIO % lag2).replace("T: 0.25}", f"T: 0.25, interface: model_exchange, {solver}}}")
    system = loads(text, source="me.yaml")
    assert system.components["lag"].me
    r = simulate(system)
    expected = 2.0 * 1.5 * (1.0 - np.exp(-r["time"] / 0.25))
    err = np.max(np.abs(r["lag.y[1]"] - expected))
    assert 0 < err < bound


def test_failed_instantiation_carries_the_log_and_frees_nothing(tmp_path, monkeypatch) -> None:
    from fmpy.fmi2 import FMU2Slave

    calls: list[str] = []
    for name in ("terminate", "freeInstance"):
        monkeypatch.setattr(FMU2Slave, name, lambda self, _n=name: calls.append(_n))
    faulty = build_c_fmu("faulty", tmp_path)
    scenario = f"""
components:
  refuse: {{kind: fmu, parameters: {{path: {faulty}}}}}
open: [refuse.u]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
"""
    with pytest.raises(FmuError) as err:
        simulate(loads(scenario, source="fmu.yaml"))
    assert "fmi2Instantiate failed" in str(err.value)
    assert any("instantiation refused on purpose" in line for line in err.value.log)
    assert calls == []


@pytest.mark.parametrize("setting, message", [
    ("interface: model_exchange, solver: euler", "solver 'euler' is unknown"),
    ("interface: model_exchange, rtol: -1.0e-6", "rtol = -1e-06 must be a positive number"),
    ("interface: model_exchange, solver_step: 0", "solver_step = 0 must be a positive number"),
    ("solver: rk4, rtol: 1.0e-8", "solver, rtol given, but 'lag2.fmu' runs as co-simulation"),
    ("interface: co_simulation, max_step: 0.1", "max_step given, but 'lag2.fmu' runs as "
                                                "co-simulation"),
    ("isolate: 'yes'", "isolate: 'yes' is not true or false"),
    ("isolate: true, timeout: 0", "timeout 0 is not positive"),
    ("interface: model_exchange, solver: rk4, k: [1, 2]", "expected a scalar"),
])
def test_bad_fmu_settings_are_refused_at_check_with_their_line(lag2, setting, message) -> None:
    text = (SCENARIO % lag2).replace("T: 0.25}", f"T: 0.25, {setting}}}")
    with pytest.raises(ScenarioError) as err:
        loads(text, source="fmu.yaml")
    assert "fmu.yaml:6" in str(err.value) and message in str(err.value)


def test_a_library_not_named_after_the_model_identifier_is_refused_when_loaded(lag2,
                                                                                tmp_path) -> None:
    renamed = tmp_path / "renamed.fmu"
    with zipfile.ZipFile(lag2) as zin, zipfile.ZipFile(renamed, "w") as zout:
        for item in zin.namelist():
            zout.writestr(item.replace("lag2.so", "other.so"), zin.read(item))
    with pytest.raises(FmuError, match=r"binaries/linux64/lag2\.so"):
        FmuComponent("x", renamed)


def test_an_fmi2_fmu_that_ends_the_simulation_says_so(tmp_path) -> None:
    faulty = build_c_fmu("faulty", tmp_path)
    scenario = f"""
components:
  f: {{kind: fmu, parameters: {{path: {faulty}, mode: 6, fail_after: 4}}}}
open: [f.u]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
"""
    with pytest.raises(FmuError, match=r"asked to terminate the simulation.*fmi2Terminated"):
        simulate(loads(scenario, source="fmu.yaml"))


def test_inspect_of_a_bad_start_value_is_an_error_not_a_traceback(lag2, tmp_path) -> None:
    from twmr.fmi import describe_fmu

    bad = tmp_path / "badstart.fmu"
    with zipfile.ZipFile(lag2) as zin, zipfile.ZipFile(bad, "w") as zout:
        for item in zin.namelist():
            data = zin.read(item)
            if item == "modelDescription.xml":
                data = data.replace(b'<Real start="2.0"/>', b'<Real start="two"/>')
            zout.writestr(item, data)
    with pytest.raises(FmuError, match="start=\"two\", which is not a valid Real"):
        describe_fmu(bad)
