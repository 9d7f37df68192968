"""`events:` faults on ports: a `port_fault` block on the port's wires, so the rows change exactly
at the event's time, alike in the Python schedule and the compiled loop, and with an FMU reading
the faulty port; the port keeps its own value in the results; the events are in summary.json;
bad events are refused at check, each at its line."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.conformance.corpus import corpus
from twmr.core.errors import CosimError

pytestmark = pytest.mark.timeout(120)

BASE = """components:
  src: {kind: ramp, parameters: {slope: 1.0}}
  g: {kind: gain, parameters: {k: 2.0}}
  i: {kind: integrator}
connections: [src.y -> g.u, g.y -> i.u]
experiment: {stop: 0.1, step: 0.01}
events:
%s
"""
FAULTS = """  - {at: 0.05, until: 0.08, port: src.y, fault: freeze}
  - {at: 0.03, port: i.u, fault: bias, value: 1.0}"""


def test_faults_change_the_rows_at_their_times_in_every_loop(tmp_path: Path) -> None:
    scenario = twmr.load(BASE % FAULTS)
    python = twmr.simulate(scenario, tmp_path / "py", compiled="off")
    compiled = twmr.simulate(scenario, tmp_path / "c", compiled="on")
    assert np.array_equal(python.values, compiled.values)
    t, src, g = python["time"], python["src.y"], python["g.y"]
    np.testing.assert_allclose(src, t, atol=1e-15)  # the faulted port keeps its own value
    frozen = (t >= 0.05 - 1e-12) & (t < 0.08 - 1e-12)
    np.testing.assert_allclose(g[frozen], 2 * 0.04, atol=1e-15)  # the last value before 0.05
    np.testing.assert_allclose(g[~frozen], 2 * t[~frozen], atol=1e-15)
    # i integrates g, plus 1 from 0.03 on (the bias on its input): exact for the Euler sum
    u = g + np.where(t >= 0.03 - 1e-12, 1.0, 0.0)
    np.testing.assert_allclose(python["i.y"][1:], np.cumsum(u[:-1]) * 0.01, atol=1e-12)
    summary = json.loads((tmp_path / "py" / "summary.json").read_text())
    assert [(e["at"], e["until"], e["port"], e["fault"]) for e in summary["events"]] == \
        [(0.05, 0.08, "src.y", "freeze"), (0.03, None, "i.u", "bias")]


def test_noise_is_the_seeds_in_python_and_compiled() -> None:
    text = BASE % "  - {at: 0.0, port: src.y, fault: noise, value: 0.5, seed: %d}"
    runs = {(seed, c): twmr.simulate(twmr.load(text % seed), compiled=c)["g.y"]
            for seed in (1, 2) for c in ("off", "on")}
    assert np.array_equal(runs[1, "off"], runs[1, "on"])
    assert not np.array_equal(runs[1, "off"], runs[2, "off"])
    t = np.arange(11) * 0.01
    assert np.std(runs[1, "off"] - 2 * t) > 0.1  # 2 x 0.5 N(0, 1)


def test_an_fmu_reads_the_faulty_port(tmp_path: Path) -> None:
    fmu = corpus("reference-fmus", "Feedthrough_fmi2.fmu")
    text = f"""components:
  src: {{kind: ramp, parameters: {{slope: 1.0}}}}
  ft: {{kind: fmu, parameters: {{path: '{fmu}'}}}}
connections: [src.y -> ft.Float64_continuous_input]
open: ['ft.*']
experiment: {{stop: 0.1, step: 0.01}}
record: {{signals: [src.y, ft.Float64_continuous_output]}}
events:
  - {{at: 0.04, port: src.y, fault: stuck_at, value: -3.0}}
"""
    result = twmr.simulate(twmr.load(text))
    t, out = result["time"], result["ft.Float64_continuous_output"]
    late = t >= 0.04 - 1e-12
    np.testing.assert_allclose(out[late], -3.0)
    np.testing.assert_allclose(out[~late], t[~late], atol=1e-15)


@pytest.mark.parametrize("event, said", [
    ("{at: 5.0, port: src.y, fault: freeze}", "outside the run"),
    ("{at: 0.0, port: src.z, fault: freeze}", "has no port 'z'"),
    ("{at: 0.0, port: srx.y, fault: freeze}", "names no component"),
    ("{at: 0.0, port: src.y, fault: melt}", "'melt' is not one of"),
    ("{at: 0.05, until: 0.01, port: src.y, fault: bias}", "is not after"),
    ("{at: 0.0, port: i.y, fault: bias}", "is on no wire"),
])
def test_bad_events_are_refused_at_their_line(tmp_path: Path, event: str, said: str) -> None:
    path = tmp_path / "faults.yaml"
    path.write_text(BASE % f"  - {event}")
    with pytest.raises(CosimError, match=said) as err:
        twmr.load(path)
    assert "faults.yaml:8" in str(err.value)


def test_a_fault_on_one_element_leaves_the_others_alone() -> None:
    """`port: "ctrl.torque[2]"`: the right wheel's torque passes as computed, the left's is
    stuck at 3 N.m from 1 s; an element that does not exist is refused at check."""
    from twmr.core.errors import ScenarioError

    path = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"
    text = path.read_text(encoding="utf-8")
    r = twmr.simulate(twmr.load(text + 'events:\n  - {at: 1.0, port: "ctrl.torque[2]", '
                                       'fault: stuck_at, value: 3.0}\n',
                                ["experiment.stop=2"]))
    t = np.asarray(r["time"])
    right, left = np.asarray(r["motor.torque[1]"]), np.asarray(r["motor.torque[2]"])
    assert np.all(left[t >= 1.0] == 3.0) and np.all(left[t < 1.0] != 3.0)
    assert np.array_equal(right, np.clip(np.asarray(r["ctrl.torque[1]"]), -48.0, 48.0))
    assert r.summary["events"][0]["port"] == "ctrl.torque[2]"
    with pytest.raises(ScenarioError, match=r"has 2 element\(s\); element 3 does not exist"):
        twmr.load(text + 'events:\n  - {at: 1.0, port: "ctrl.torque[3]", fault: freeze}\n')
