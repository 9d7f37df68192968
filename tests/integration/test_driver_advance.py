"""The lean steps (`Kernel.advance`, `twmr.master.plan.advancing`) of the compiled driver, of
the loop generated for a scenario and of the Python schedule: under Gauss-Seidel the ASMC's and
the slip block's steps leave their feedthrough outputs to the next point's evaluation, under
Jacobi they do not, the rows equal those of the Python schedule with whole steps only bit for
bit, and after every chunk of steps the components hold what that schedule leaves them."""
from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tests.integration.test_compiled import ROOT
from twmr.master import Execution, execution, schedule
from twmr.master.algorithm import make_algorithm
from twmr.master.compiled import CompiledStep
from twmr.observers.base import Observer
from twmr.observers.store import ResultStore
from twmr.scenario import load

PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
#: the ports the steps write that the next point's evaluation recomputes, and d_hat
PORTS = ("ctrl.torque", "ctrl.error", "ctrl.s", "ctrl.d_hat", "slip.slip_rate",
         "slip.disturbance", "plant.pose", "motor.torque")


class AfterChunks(Observer):
    """The values of `PORTS` in the components after each chunk of steps."""

    def __init__(self, system: Any) -> None:
        self.system, self.seen = system, []

    def rows(self, block: np.ndarray, steps_done: int) -> None:
        comps = self.system.components
        self.seen.append((steps_done, [np.ravel(comps[p.split(".")[0]].get(p.split(".")[1]))
                                       for p in PORTS]))


def run(method: str, mode: str, use_driver: bool = True) -> tuple[np.ndarray, list, Any]:
    system = load(PAPER, ["experiment.stop=2.0", f"experiment.algorithm={method}"])
    algorithm = make_algorithm(method, mode) if mode == "off" else \
        CompiledStep(method, mode, use_driver=use_driver)
    store, after = ResultStore(), AfterChunks(system)
    out = Execution(system, [store, after], algorithm=algorithm).run()
    assert out.status == "completed", out.error
    return store.data(), after.seen, algorithm


@pytest.mark.parametrize("method", ["gauss_seidel", "jacobi"])
def test_lean_steps_give_the_python_schedule_s_rows_and_chunk_ends(
        method: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(execution, "CHUNK_SECONDS", 1e9)  # chunks of 64, 256, ... steps in all
    with monkeypatch.context() as whole_steps:
        whole_steps.setattr(schedule, "advancing", lambda system, plan: frozenset())
        whole, whole_seen, _ = run(method, "off")
    python, python_seen, python_alg = run(method, "off")
    compiled, seen, alg = run(method, "on")
    loop, loop_seen, loop_alg = run(method, "on", use_driver=False)
    assert loop_alg.compiled and not loop_alg.use_driver
    lay, order = alg._layout, alg.python.plan.order
    lean = {order[b] for b, _m, flag in lay.steps if flag}
    expected_lean = {"ctrl", "slip"} if method == "gauss_seidel" else set()
    assert lean == expected_lean
    ids = {name: i for i, name in enumerate(order)}
    assert {n for n in order if f"ad{ids[n]}(t, " in python_alg.source} == expected_lean
    assert {n for n in order if f"= ad{ids[n]}(t, " in loop_alg.source} == expected_lean
    for rows, chunk_ends in ((python, python_seen), (compiled, seen), (loop, loop_seen)):
        assert np.array_equal(rows, whole)
        assert [n for n, _ in chunk_ends] == [n for n, _ in whole_seen] and len(chunk_ends) > 2
        for (n, values), (_, expected) in zip(chunk_ends, whole_seen, strict=True):
            for port, v, e in zip(PORTS, values, expected, strict=True):
                assert np.array_equal(v, e), (n, port, v, e)
