"""`experiment.realtime` takes a factor: a paced run's step n is due at t0 + n h / factor (checked
on the pacer's own deadlines, not on how long the run took); a factor other than 1 with hardware
in the loop, and one that is no finite positive number, are refused at check."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core.errors import CosimError
from twmr.master import Execution
from twmr.observers.store import ResultStore

pytestmark = pytest.mark.timeout(60)

RAMP = """components:
  src: {kind: ramp, parameters: {slope: 1.0}}
experiment: {stop: 0.05, step: 0.01, realtime: %s}
"""


@pytest.mark.parametrize("given, factor", [("true", 1.0), ("4", 4.0), ("0.5", 0.5)])
def test_a_paced_step_is_due_at_its_time_over_the_factor(given: str, factor: float) -> None:
    system = twmr.load(RAMP % given).fresh_system()
    assert system.paced and system.pace_factor == factor
    ex = Execution(system, [store := ResultStore()])
    ex.run()
    assert ex.pacer is not None
    deadlines = np.diff(np.asarray(ex.pacer.deadline_ns, dtype=np.int64))
    assert set(deadlines.tolist()) == {round(0.01 / factor * 1e9)}
    np.testing.assert_allclose(store.data()[:, 1], store.data()[:, 0], atol=1e-15)


def test_false_is_not_paced() -> None:
    system = twmr.load(RAMP % "false").system
    assert not system.paced


@pytest.mark.parametrize("given, said", [("0", "less than or equal to the minimum"),
                                         ("-2", "less than or equal to the minimum"),
                                         (".inf", "no real-time factor")])
def test_a_factor_that_is_no_positive_number_is_refused(given: str, said: str) -> None:
    with pytest.raises(CosimError, match=said):
        twmr.load(RAMP % given)


def test_a_factor_with_hardware_is_refused(tmp_path: Path) -> None:
    text = """components:
  motor: {kind: can_drive}
open: [motor.torque_command, motor.wheel_speed]
experiment: {stop: 0.05, step: 0.01, realtime: 2}
"""
    with pytest.raises(CosimError, match=r"realtime: 2 with hardware in the loop \(motor\)"):
        twmr.load(text)


def test_the_factor_survives_an_ssp_round_trip(tmp_path: Path) -> None:
    from twmr.fmi.ssp.write import export_ssp

    source = tmp_path / "ramp.yaml"
    source.write_text(RAMP % "4")
    path = tmp_path / "ramp.ssp"
    export_ssp(source, path)
    assert twmr.load(path).system.pace_factor == 4.0
