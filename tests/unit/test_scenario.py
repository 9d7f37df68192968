"""Scenario loading: a valid file builds; each kind of bad input gives a located, fixable error."""
from __future__ import annotations

from pathlib import Path

import pytest

from twmr.core import AlgebraicLoopError, CosimError, ScenarioError, WiringError
from twmr.core.units import conversion
from twmr.scenario import describe, kinds_table, load, loads

FIXTURE = Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml"
GOOD = FIXTURE.read_text()


def error_of(text: str, cls: type[CosimError] = ScenarioError) -> str:
    with pytest.raises(cls) as err:
        loads(text, source="s.yaml")
    return str(err.value)


def test_valid_scenario_builds_in_feedthrough_order() -> None:
    system = load(FIXTURE)
    assert system.order.index("err") < system.order.index("ctrl")
    assert system.record.signals == (("plant", "u"), ("plant", "y"), ("ctrl", "y"))
    assert system.record.decimation == 2
    assert system.experiment.n_steps == 100
    text = describe(system)
    assert "plant.y -> err.u2" in text and "the order they step in" in text
    # ref and plant have no feedthrough; err feeds ctrl: evaluated err, then ctrl
    assert text.splitlines()[7].endswith("evaluated in this order (`evaluate`): err, ctrl"), text


def test_yaml_syntax_error_names_the_line() -> None:
    bad = GOOD.replace("  ctrl: {kind: gain, parameters: {k: 2.0}}", "  ctrl: {kind: gain,, [")
    text = error_of(bad)
    assert "s.yaml:5" in text and "YAML syntax error" in text and "Fix:" in text


def test_unknown_key_has_did_you_mean() -> None:
    text = error_of(GOOD.replace("record:", "recrod:"))
    assert "s.yaml:13" in text and "unknown key 'recrod'" in text
    assert "did you mean 'record'" in text


def test_unknown_kind_suggests() -> None:
    text = error_of(GOOD.replace("kind: integrator", "kind: integrater"))
    assert "s.yaml:6" in text and "'plant'" in text and "did you mean 'integrator'" in text


def test_parameter_unknown_wrong_type_and_out_of_range() -> None:
    text = error_of(GOOD.replace("{k: 2.0}", "{kk: 2.0}"))
    assert "s.yaml:5" in text and "no parameter 'kk'" in text and "did you mean 'k'" in text
    text = error_of(GOOD.replace("{k: 2.0}", "{k: fast}"))
    assert "'ctrl'" in text and "parameter 'k'" in text and "Fix:" in text


def test_out_of_range_parameter() -> None:
    text = error_of(GOOD.replace("ref: {kind: step, parameters: {height: 1.0, time: 0.1}}",
                                 "ref: {kind: sine, parameters: {frequency: -1.0}}")
                    .replace("time: 0.1", ""))
    assert "'ref'" in text and "frequency" in text and "below the minimum" in text


def test_parameter_with_unit_is_converted() -> None:
    system = loads(GOOD.replace("{height: 1.0, time: 0.1}", "{height: 1.0, time: 100 ms}"))
    assert system.components["ref"].time == pytest.approx(0.1)
    system = loads(GOOD.replace("{height: 1.0, time: 0.1}", "{height: 1.0, time: 1e-1}"))
    assert system.components["ref"].time == 0.1  # YAML 1.1 reads 1e-1 as text


def test_missing_port_output_to_output_and_double_driver() -> None:
    text = error_of(GOOD.replace("- err.y -> ctrl.u", "- err.yy -> ctrl.u"), WiringError)
    assert "s.yaml:10" in text and "no port 'yy'" in text and "did you mean 'y'" in text
    text = error_of(GOOD.replace("- err.y -> ctrl.u", "- err.y -> ctrl.y"), WiringError)
    assert "output-to-output" in text and "'ctrl.y'" in text
    text = error_of(GOOD.replace("- err.y -> ctrl.u", "- err.y -> ctrl.u\n  - ref.y -> ctrl.u"),
                    WiringError)
    assert "driven twice" in text and "s.yaml:11" in text


def test_unconnected_input_unless_open() -> None:
    cut = GOOD.replace("  - plant.y -> err.u2\n", "")
    text = error_of(cut, WiringError)
    assert "'err.u2' is not connected" in text and "open:" in text
    system = loads(cut + "open: [err.u2]\n")
    assert "err.u2 = 0.0" in describe(system)


def test_algebraic_loop_prints_the_cycle_and_the_fix() -> None:
    looped = GOOD.replace("plant: {kind: integrator}", "plant: {kind: gain}")
    text = error_of(looped, AlgebraicLoopError)
    assert "algebraic loop" in text and "err.y -> ctrl.u" in text and "ctrl.y -> plant.u" in text
    assert "plant.y -> err.u2" in text and "delay" in text


def test_bad_experiment() -> None:
    assert "must be after start" in error_of(GOOD.replace("stop: 1.0", "stop: -1.0"))
    assert "step must be > 0" in error_of(GOOD.replace("step: 0.01", "step: 0.0"))
    assert "whole number of steps" in error_of(GOOD.replace("step: 0.01", "step: 0.03"))


def test_unit_conversion_is_folded_into_the_wire() -> None:

    assert conversion("mm", "m") == (pytest.approx(1e-3), 0.0)
    assert conversion("deg", "rad")[0] == pytest.approx(3.141592653589793 / 180)
    with pytest.raises(CosimError):
        conversion("N.m", "rad/s")


def test_overrides_set_parameters_and_report_unknown_components() -> None:
    system = load(FIXTURE, ["ctrl.k=5", "ref.time=0.2"])
    assert system.components["ctrl"].k == 5.0
    with pytest.raises(ScenarioError, match="did you mean 'ctrl'"):
        load(FIXTURE, ["ctrll.k=5"])


def test_components_table_lists_ports_and_units() -> None:
    text = kinds_table(["sine", "state_space"])
    assert "frequency [Hz]" in text and "output    y" in text


def test_size_mismatch_and_unit_conversion_in_wires() -> None:
    text = """
components:
  plant: {kind: twmr_plant}
  ref: {kind: trajectory}
connections:
  - ref.position -> plant.torque
experiment: {stop: 1.0, step: 0.1}
"""
    msg = error_of(text.replace("ref.position -> plant.torque", "ref.position -> plant.slip_rate"),
                   WiringError)
    assert "size mismatch" in msg and "gives 2 value(s)" in msg and "s.yaml:6" in msg
    msg = error_of(text, WiringError)
    assert "unit mismatch" in msg and "'m'" in msg and "'N.m'" in msg
