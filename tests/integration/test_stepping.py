"""`twmr.Stepping`: a run taken step by step (as libcosim's execution is) gives the rows of the
run taken at once, in the Python schedule and the compiled loop; a parameter set between steps
gives the rows of the timed set event at that time; a stopped run keeps its rows (status
'stopped', its folder readable); calls that cannot be are refused with a fix."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core.errors import CosimError
from twmr.master.gate import Gate

pytestmark = pytest.mark.timeout(300)
ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
SHORT = ["experiment.stop=1.0"]


@pytest.mark.parametrize("compiled", ["off", "on"])
def test_a_run_taken_step_by_step_is_the_run_taken_at_once(compiled: str) -> None:
    whole = twmr.simulate(twmr.load(PAPER, SHORT), compiled=compiled)
    with twmr.Stepping(twmr.load(PAPER, SHORT), compiled=compiled) as run:
        assert (run.steps, run.time) == (0, 0.0)
        assert run.step() == pytest.approx(0.001)
        assert run.step(12) == pytest.approx(0.013)
        assert run.simulate_until(0.4567) == pytest.approx(0.457)
        pose = run.value("plant.pose")
        run.simulate_until(0.5)
        stepped = run.finish()
    assert stepped.summary["status"] == "completed"
    assert stepped.summary["pacing"].get("algorithm.compiled", False) is (compiled == "on")
    assert np.array_equal(stepped.values, whole.values)
    row = int(np.searchsorted(whole["time"], 0.457 - 1e-12))
    # the pose read at 0.457 s is the one recorded there (decimation 10: 0.457 is no row; the
    # state's value at the step is checked against the next recorded row's direction instead)
    assert len(pose) == 3 and all(np.isfinite(pose))
    assert abs(pose[0] - whole["plant.pose[1]"][row]) < 0.01


def test_a_parameter_set_between_steps_is_a_set_event_at_that_time() -> None:
    text = PAPER.read_text(encoding="utf-8") + (
        "events:\n  - {at: 0.25, set: plant.scale, value: 1.6}\n")
    event = twmr.simulate(twmr.load(text, SHORT))
    with twmr.Stepping(twmr.load(PAPER, SHORT)) as run:
        run.simulate_until(0.25)
        run.set("plant.scale", 1.6)
        stepped = run.finish()
    assert np.array_equal(stepped.values, event.values)
    plain = twmr.simulate(twmr.load(PAPER, SHORT))
    assert not np.array_equal(stepped.values, plain.values)


def test_a_stopped_run_keeps_its_rows_and_its_folder(tmp_path: Path) -> None:
    with twmr.Stepping(twmr.load(PAPER, SHORT), tmp_path / "run") as run:
        run.simulate_until(0.3)
        result = run.stop()
    assert result.summary["status"] == "stopped" and result.summary["steps_done"] == 300
    back = twmr.read_result(tmp_path / "run")
    assert back.summary["status"] == "stopped" and len(back) == 30  # rows 0 .. 0.29 s
    whole = twmr.simulate(twmr.load(PAPER, SHORT))
    assert np.array_equal(back.values, whole.values[:30])


def test_calls_that_cannot_be_are_refused_with_a_fix() -> None:
    with twmr.Stepping(twmr.load(PAPER, SHORT)) as run:
        run.simulate_until(0.2)
        for call, said in ((lambda: run.step(-1), "steps forward only"),
                           (lambda: run.simulate_until(0.1), "steps forward only"),
                           (lambda: run.value("plant.nope"), "no such port"),
                           (lambda: run.set("plant.nope", 1.0), "has no parameter 'nope'"),
                           (lambda: run.set("plant.scale", -1.0), "cannot take")):
            with pytest.raises(CosimError, match="Fix:") as caught:
                call()
            assert said in str(caught.value)
        assert run.simulate_until(5.0) == pytest.approx(1.0)  # at most the stop time
        assert run.ended
        with pytest.raises(CosimError, match="has ended"):
            run.set("plant.scale", 1.1)


def test_leaving_the_block_stops_the_run_and_a_gate_waits_for_nothing_after() -> None:
    with twmr.Stepping(twmr.load(PAPER, SHORT)) as run:
        run.step(3)
        gate = run._gate
    assert gate.ended and gate.wait_for(10**9, timeout=5.0) is False


def test_a_paced_run_does_not_catch_up_the_time_it_was_paused() -> None:
    """The pacer's deadlines move by the pause (t0 + n h + paused)."""
    from twmr.master.execution import Pacer

    pacer = Pacer(1e-3)
    pacer.start()
    t0 = pacer.t0
    pacer.shift(0.25)
    pacer.shift(-1.0)  # nothing to undo
    assert pacer.t0 - t0 == 250_000_000


def test_a_gate_grants_steps_and_stops_between_them() -> None:
    gate = Gate(paused=True)
    import threading

    seen: list[int] = []

    def run() -> None:
        n = 0
        try:
            while n < 100:
                limit = gate.allowed(n)
                n = min(limit, n + 7)
                gate.reached(n)
                seen.append(n)
        except Exception as exc:  # noqa: BLE001 - the stop, looked at below
            seen.append(-1 if type(exc).__name__ == "RunStopped" else -2)
        finally:
            gate.end()

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    gate.grant(10)
    assert gate.wait_for(10, timeout=30)
    assert seen == [7, 10]
    gate.grant_to(30)
    assert gate.wait_for(30, timeout=30) and seen[-1] == 30
    gate.stop()
    worker.join(30)
    assert seen[-1] == -1 and gate.ended
