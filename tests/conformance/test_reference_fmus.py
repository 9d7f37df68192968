"""The Modelica Association's Reference FMUs (FMI 2.0 and 3.0, co-simulation) run as fmpy's
`simulate_fmu` runs them, at each FMU's default experiment: every real and integer output equal
at every communication point. Clocks (scheduled execution only) is refused at check with that
reason."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.conformance.corpus import corpus
from twmr.core.errors import ScenarioError

pytestmark = pytest.mark.timeout(240)

#: (FMU, stop [s] when its default one is too long for a test, largest |twmr - fmpy|)
CASES = [
    ("BouncingBall_fmi2.fmu", None, 0.0),
    ("BouncingBall_fmi3.fmu", None, 0.0),
    ("Dahlquist_fmi2.fmu", None, 0.0),
    ("Dahlquist_fmi3.fmu", None, 0.0),
    ("Feedthrough_fmi2.fmu", None, 0.0),
    ("Feedthrough_fmi3.fmu", None, 0.0),
    ("Resource_fmi2.fmu", None, 0.0),
    ("Resource_fmi3.fmu", None, 0.0),
    ("Stair_fmi2.fmu", None, 0.0),
    ("Stair_fmi3.fmu", None, 0.0),
    ("VanDerPol_fmi2.fmu", None, 0.0),
    ("VanDerPol_fmi3.fmu", None, 0.0),
    ("StateSpace_fmi3.fmu", None, 0.0),
    # its binary refuses the event mode its XML declares, so it runs without, as fmpy does;
    # fmpy passes each step as the difference of two grid times (t_n+1 - t_n), twmr as the
    # step itself, which moves the FMU's fixed internal 1 ms steps by a few ulps at times
    ("Roberts_fmi3.fmu", 1.00001, 1e-7),
]


def _outputs(md: object) -> list[str]:
    return [v.name for v in md.modelVariables  # type: ignore[attr-defined]
            if v.causality == "output" and v.type in ("Real", "Float64", "Float32", "Integer",
                                                      "Int32", "Int64")]


@pytest.mark.parametrize(("name", "stop", "tolerance"), CASES, ids=[c[0] for c in CASES])
def test_reference_fmu_equals_fmpy(name: str, stop: float | None, tolerance: float,
                                   tmp_path: Path) -> None:
    fmpy = pytest.importorskip("fmpy")
    path = corpus("reference-fmus", name)
    md = fmpy.read_model_description(str(path))
    exp = md.defaultExperiment
    start = float(exp.startTime) if exp and exp.startTime else 0.0
    stop = stop or (float(exp.stopTime) if exp and exp.stopTime else 1.0)
    step = float(exp.stepSize) if exp and exp.stepSize else 0.01
    outputs = _outputs(md)
    reference = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", start_time=start,
                                  stop_time=stop, output_interval=step, output=outputs)
    inputs = any(v.causality == "input" for v in md.modelVariables)
    scenario = twmr.load({
        "components": {"m": {"kind": "fmu", "parameters": {
            "path": str(path), "interface": "co_simulation"}}},
        "open": ["m.*"] if inputs else [],
        # Stair asks to end the simulation at its last stair; fmpy ends the run there
        "experiment": {"start": start, "stop": stop, "step": step, "fmu_terminate": "stop"},
    })
    rows = twmr.simulate(scenario, out=str(tmp_path / "run")).to_pandas()
    if name.startswith("Stair"):
        # the FMU asks to end in the step to 9 s; the run ends at the last communication point
        # every component completed (8.8 s), where fmpy records the FMU's state at 9 s as well
        assert rows["time"].iloc[-1] == pytest.approx(reference["time"][-1] - step)
        reference = reference[:len(rows)]
    assert len(rows) == len(reference)
    np.testing.assert_array_equal(rows["time"].to_numpy(), reference["time"])
    for name_ in outputs:
        ours = rows[[c for c in rows.columns
                     if c == f"m.{name_}" or c.startswith(f"m.{name_}[")]].to_numpy()
        theirs = np.asarray(reference[name_], dtype=float).reshape(len(reference), -1)
        if name_ == "h_ft":  # an FMI 3 alias in its own display unit: a port in feet
            theirs = theirs * 3.280839895  # the FMU's <DisplayUnit name="ft" factor=...>
        np.testing.assert_allclose(ours, theirs, rtol=1e-15 if tolerance == 0 else 0,
                                   atol=tolerance, err_msg=f"{name}: {name_}")


def test_scheduled_execution_fmu_is_refused_at_check() -> None:
    path = corpus("reference-fmus", "Clocks_fmi3.fmu")
    with pytest.raises(ScenarioError, match="offers only scheduled execution"):
        twmr.load({"components": {"m": {"kind": "fmu", "parameters": {"path": str(path)}}},
                   "experiment": {"start": 0, "stop": 1, "step": 0.01}})


def _adaptive(name: str) -> dict[str, object]:
    return {"components": {"ball": {"kind": "fmu", "parameters": {
        "path": str(corpus("reference-fmus", name)), "interface": "co_simulation"}}},
        "experiment": {"start": 0, "stop": 1.0, "step": 1e-3, "algorithm": "adaptive",
                       "max_step": 0.1}}


def test_adaptive_says_at_check_that_fmi2_cs_events_are_unseen(
        caplog: pytest.LogCaptureFixture) -> None:
    from twmr.master.algorithm import algorithm_for

    with caplog.at_level("WARNING", logger="twmr"):
        algorithm_for(twmr.load(_adaptive("BouncingBall_fmi2.fmu")).system)
    assert "component 'ball': it runs as FMI 2.0 co-simulation" in caplog.text
    assert "within the step that holds it (up to max_step = 0.1 s)" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="twmr"):  # no state events: nothing to say
        algorithm_for(twmr.load({**_adaptive("Dahlquist_fmi2.fmu")}).system)
    assert "co-simulation" not in caplog.text


def test_adaptive_locates_an_fmi3_bounce_by_early_return(caplog: pytest.LogCaptureFixture
                                                         ) -> None:
    with caplog.at_level("WARNING", logger="twmr"):
        rows = twmr.simulate(_adaptive("BouncingBall_fmi3.fmu")).to_pandas()
    assert "co-simulation" not in caplog.text
    bounce = (2 * 1.0 / 9.81) ** 0.5  # h(0) = 1 m, g = 9.81 m/s2: 0.4515 s
    after = rows[rows["ball.v"] > 0]["time"].iloc[0]  # the first row moving up
    # the grid point at or after the FMU's own bounce (its fixed internal step puts that a
    # hair after the exact one), not somewhere within a max_step of 0.1 s
    assert bounce <= after <= bounce + 2e-3
