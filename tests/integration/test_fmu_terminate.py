"""An FMU that asks to end the simulation (fmi2DoStep returns Discard with fmi2Terminated, the
faulty test FMU's mode 6): by default the run fails naming it; with
`experiment.fmu_terminate: stop` the run ends normally there, with the rows fmpy's own
simulate_fmu records up to the last communication point, in process, isolated and in the compiled
loop. (fmpy adds a row at the FMU's own last successful time; in a system the other blocks have
not reached it, so the run's last row is the last point every block reached.)"""
from __future__ import annotations

import json

import numpy as np
import pytest
from fmpy import simulate_fmu

import twmr
from tests.fmu_build import build_c_fmu
from twmr.core.errors import FmuError, ScenarioError
from twmr.scenario import loads

FAIL_AFTER = 4


@pytest.fixture(scope="module")
def faulty(tmp_path_factory) -> str:
    return str(build_c_fmu("faulty", tmp_path_factory.mktemp("fmus")))


def scenario(fmu: str, ending: str | None, isolate: bool = False) -> str:
    option = f", fmu_terminate: {ending}" if ending else ""
    return f"""
components:
  f: {{kind: fmu, parameters: {{path: {fmu}, mode: 6, fail_after: {FAIL_AFTER},
       isolate: {str(isolate).lower()}}}}}
open: [f.u]
experiment: {{start: 0.0, stop: 1.0, step: 0.1{option}}}
"""


@pytest.mark.parametrize("ending", [None, "error"])
def test_by_default_an_fmu_that_ends_the_simulation_fails_the_run(faulty, tmp_path,
                                                                   ending) -> None:
    path = tmp_path / "end.yaml"
    path.write_text(scenario(faulty, ending))
    with pytest.raises(FmuError, match=r"asked to terminate the simulation"):
        twmr.simulate(path)


@pytest.mark.parametrize("isolate, compiled", [(False, "off"), (True, "off"), (False, "on")])
def test_stop_ends_the_run_where_the_fmu_asked_with_fmpys_rows(faulty, tmp_path, monkeypatch,
                                                               isolate, compiled) -> None:
    monkeypatch.setenv("TWMR_COMPILED", compiled)
    path = tmp_path / "end.yaml"
    path.write_text(scenario(faulty, "stop", isolate))
    result = twmr.simulate(path, tmp_path / "run")
    ref = simulate_fmu(faulty, stop_time=1.0, output_interval=0.1, output=["y"],
                       start_values={"mode": 6, "fail_after": FAIL_AFTER})
    assert ref["time"][-1] == pytest.approx(0.1 * FAIL_AFTER)  # the step the FMU ended in
    np.testing.assert_allclose(result["time"], ref["time"][:-1], atol=1e-12)
    np.testing.assert_array_equal(result["f.y"], ref["y"][:-1])
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["status"] == "completed"
    assert summary["stopped_by"] == {"component": "f",
                                     "time": pytest.approx(0.1 * (FAIL_AFTER - 1))}
    assert summary["steps_done"] == FAIL_AFTER - 1
    assert not (tmp_path / "run.incomplete").exists()


def test_stop_is_refused_for_anything_but_error_or_stop(faulty) -> None:
    with pytest.raises(ScenarioError, match=r"end\.yaml.*fmu_terminate"):
        loads(scenario(faulty, "halt"), source="end.yaml")
