"""FMI 3.0 co-simulation in event mode: output clocks driving triggered input clocks, early
return, countdown and periodic input clocks the importer schedules, clocked Binary variables;
clocks wired to values refused at check, and what stays unsupported refused as before."""
from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from tests.fmu_build import build_c_fmu, build_lsbus_fmu
from twmr.core import CosimError
from twmr.master import simulate
from twmr.scenario import loads

NODES = ("triggered", "countdown", "periodic")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, str]:
    d = tmp_path_factory.mktemp("clocks")
    found = {n: str(build_lsbus_fmu(f"cannode_{n}", d)) for n in NODES}
    found["clock3"] = str(build_c_fmu("clock3", d, fmi3=True))
    return found


def counted(fmus: dict[str, str], node: str, period: float, step: float = 0.1) -> str:
    """Node `a`'s Tx clock wired to clock3's triggered input clock `tick`."""
    return f"""
components:
  a: {{kind: fmu, parameters: {{path: {fmus[node]}, period: {period}}}}}
  c: {{kind: fmu, parameters: {{path: {fmus['clock3']}}}}}
connections:
  - a.CanChannel.Tx_Clock -> c.tick
open: [a.payload, a.CanChannel.Rx_*]
experiment: {{start: 0.0, stop: 1.0, step: {step}}}
"""


def ticked_at(r, signal: str) -> list[float]:
    return [round(float(t), 9) for t, v in zip(r["time"], r[signal], strict=True) if v]


def test_output_clock_drives_a_triggered_input_clock(fmus) -> None:
    """Ticks at 0 (the configuration) and every 0.3 s; clock3 counts each once, in the step
    from that communication point (so its count shows one point later)."""
    system = loads(counted(fmus, "triggered", 0.3), source="clocks.yaml")
    r = simulate(system)
    assert ticked_at(r, "a.CanChannel.Tx_Clock") == [0.0, 0.3, 0.6, 0.9]
    np.testing.assert_array_equal(r["c.ticks"], [0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4])
    assert system.components["a"].variables["CanChannel.Tx_Clock"].type == "Clock"


def test_early_return_is_handled_at_the_fmus_own_time(fmus) -> None:
    """Period 0.25 on a 0.1 s grid: the node returns early at 0.25, 0.5, 0.75 and sends there
    (tx_time); the tick shows at the communication point that ends the step."""
    system = loads(counted(fmus, "triggered", 0.25), source="clocks.yaml")
    r = simulate(system)
    a = system.components["a"]
    assert [round(t, 12) for t, _ in a._events.ticks] == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert ticked_at(r, "a.CanChannel.Tx_Clock") == [0.0, 0.3, 0.5, 0.8, 1.0]
    row = list(np.round(r["time"], 9)).index(0.3)
    assert r["a.tx_time"][row] == pytest.approx(0.25, abs=1e-12)


@pytest.mark.parametrize("node, period, sent", [("countdown", 0.25, [0.25, 0.5, 0.75, 1.0]),
                                                ("periodic", 0.3, [0.0, 0.3, 0.6, 0.9])])
def test_scheduled_input_clocks_tick_at_their_own_times(fmus, node, period, sent) -> None:
    """The countdown clock's interval comes from fmi3GetIntervalDecimal (the step is split at
    0.25 and 0.75); the periodic one's from intervalDecimal="0.3" (period is not used)."""
    system = loads(counted(fmus, node, period), source="clocks.yaml")
    r = simulate(system)
    a = system.components["a"]
    assert [round(t, 12) for t, _ in a._events.ticks] == sent
    assert r["a.tx_frames"][-1] == len(sent)
    row = list(np.round(r["time"], 9)).index(0.3)
    assert r["a.tx_time"][row] == pytest.approx(0.25 if node == "countdown" else 0.3, abs=1e-12)
    assert r["c.ticks"][-1] == len([t for t in sent if t < 1.0])  # the tick at stop: not seen


def test_a_periodic_clock_of_fixed_interval_asks_the_fmu(fmus, tmp_path) -> None:
    """intervalVariability="fixed": the interval is the FMU's (fmi3GetIntervalDecimal gives the
    node's period, 0.25 s); it ticks at shift 0, then every interval."""
    fixed = build_lsbus_fmu("cannode_periodic", tmp_path, {
        'intervalVariability="constant" intervalDecimal="0.3"': 'intervalVariability="fixed"'})
    system = loads(counted({**fmus, "fixed": str(fixed)}, "fixed", 0.25), source="clocks.yaml")
    simulate(system)
    assert [round(t, 12) for t, _ in system.components["a"]._events.ticks] == \
        [0.0, 0.25, 0.5, 0.75, 1.0]


def test_a_clock_wired_to_a_value_is_refused_naming_both(fmus) -> None:
    text = counted(fmus, "triggered", 0.3).replace("a.CanChannel.Tx_Clock -> c.tick",
                                                   "a.tx_frames -> c.tick")
    with pytest.raises(CosimError) as err:
        loads(text, source="clocks.yaml")
    assert "'c.tick' is a clock and 'a.tx_frames' is a Integer port" in str(err.value)


def _edited(src: str, out: Path, old: str, new: str) -> Path:
    with zipfile.ZipFile(src) as z, zipfile.ZipFile(out, "w") as w:
        for item in z.namelist():
            data = z.read(item)
            w.writestr(item, data.replace(old.encode(), new.encode())
                       if item == "modelDescription.xml" else data)
    return out


@pytest.mark.parametrize("old, new, words", [
    ('hasEventMode="true"', 'hasEventMode="false"', "has no event mode"),
    ('<CoSimulation modelIdentifier="clock3" canHandleVariableCommunicationStepSize="true" '
     'hasEventMode="true"/>', '<ScheduledExecution modelIdentifier="clock3"/>',
     "offers only scheduled execution"),
])
def test_what_stays_unsupported_is_refused_at_check(fmus, tmp_path, old, new, words) -> None:
    fmu = _edited(fmus["clock3"], tmp_path / "clock3.fmu", old, new)
    scenario = tmp_path / "clock.yaml"
    scenario.write_text(f"""
components:
  c: {{kind: fmu, parameters: {{path: {fmu}}}}}
open: [c.tick]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
""")
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "check", str(scenario)],
                          capture_output=True, text=True)
    assert done.returncode != 0 and "Traceback" not in done.stderr
    assert "clock3.fmu" in done.stderr and words in done.stderr


def test_clocks_with_a_step_multiple_are_refused(fmus) -> None:
    text = counted(fmus, "triggered", 0.3).replace("period: 0.3}}", "period: 0.3}, "
                                                   "step_multiple: 2}")
    with pytest.raises(CosimError) as err:
        loads(text, source="clocks.yaml")
    assert "component 'a' has clocks (CanChannel.Rx_Clock, CanChannel.Tx_Clock) and " \
        "step_multiple 2" in str(err.value)


def test_the_adaptive_master_ends_a_step_at_a_scheduled_tick(fmus) -> None:
    """Countdown node a (0.25 s) and triggered node b under `algorithm: adaptive` on a 0.05 s
    grid (steps up to 0.2 s): steps end at a's ticks, so b receives at 0.25 s, not at 0.3."""
    system = loads(f"""
components:
  a: {{kind: fmu, parameters: {{path: {fmus['countdown']}, period: 0.25}}}}
  b: {{kind: fmu, parameters: {{path: {fmus['triggered']}, period: 10.0}}}}
connections:
  - a.CanChannel -> b.CanChannel
open: [a.payload, b.payload]
experiment: {{start: 0.0, stop: 1.0, step: 0.05, algorithm: adaptive, max_step: 0.2}}
""", source="adaptive.yaml")
    r = simulate(system)
    assert ticked_at(r, "a.CanChannel.Tx_Clock") == [0.25, 0.5, 0.75, 1.0]
    np.testing.assert_allclose(sorted(set(r["b.rx_time"])), [-1, 0.25, 0.5, 0.75], atol=1e-9)


def test_the_adaptive_master_ends_a_step_where_an_fmu_returned_early(fmus) -> None:
    """Triggered node a (0.25 s) returns early inside a step of the adaptive master: the step
    is taken again to end at 0.25 s, where b receives the frame."""
    system = loads(f"""
components:
  a: {{kind: fmu, parameters: {{path: {fmus['triggered']}, period: 0.25}}}}
  b: {{kind: fmu, parameters: {{path: {fmus['triggered']}, period: 10.0}}}}
connections:
  - a.CanChannel -> b.CanChannel
open: [a.payload, b.payload]
experiment: {{start: 0.0, stop: 1.0, step: 0.05, algorithm: adaptive, max_step: 0.2}}
""", source="adaptive.yaml")
    r = simulate(system)
    assert ticked_at(r, "a.CanChannel.Tx_Clock") == [0.0, 0.25, 0.5, 0.75, 1.0]
    np.testing.assert_allclose(sorted(set(r["b.rx_time"])), [-1, 0.25, 0.5, 0.75], atol=1e-9)
    assert r["a.tx_frames"][-1] == 4
