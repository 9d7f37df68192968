"""Components learn what the run's algorithm does from its declared capabilities
(`RunContext.outputs_as_stepped`, `steps_retaken`), never from its name: toy algorithms under
names of their own tell a block exactly what they declare, and a CAN bus block under one that
may take steps again keeps its frame log until the end."""
from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import pytest

from twmr import Component, Input, Output
from twmr.core.run import RunContext
from twmr.hw.canbus_block import CanBus
from twmr.master import Execution
from twmr.master.algorithm import Algorithm
from twmr.master.schedule import FixedStep
from twmr.observers.store import ResultStore
from twmr.scenario import loads


class Probe(Component):
    """Notes what each run told it."""

    told: ClassVar[list[tuple[bool, bool]]] = []
    u = Input()
    y = Output()

    def prepare(self, run: RunContext) -> None:
        Probe.told.append((run.outputs_as_stepped, run.steps_retaken))


class Toy(Algorithm):
    """A toy under a name of its own, declaring what it is constructed with."""

    def __init__(self, outputs_as_stepped: bool, rollback: bool) -> None:
        self.inner = FixedStep("jacobi" if outputs_as_stepped else "gauss_seidel")
        self.outputs_as_stepped = outputs_as_stepped
        self.needs_state_rollback = rollback  # type: ignore[misc]

    def prepare(self, *args: Any, **kwargs: Any) -> None:
        self.inner.prepare(*args, **kwargs)

    def advance(self, n0: int, n1: int, rows: list[Any]) -> int:
        return self.inner.advance(n0, n1, rows)

    def finish(self, n: int, rows: list[Any]) -> None:
        self.inner.finish(n, rows)


@pytest.fixture(autouse=True)
def _blocks_of_this_module(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TWMR_ALLOW_CODE", __name__.split(".")[0])  # as a user allows a package


@pytest.mark.parametrize("stepped, rollback", [(True, False), (False, True), (False, False)])
def test_a_block_is_told_the_algorithms_capabilities(stepped: bool, rollback: bool) -> None:
    system = loads(f"components:\n  p: {{kind: '{__name__}:Probe'}}\n  g: {{kind: gain}}\n"
                   "connections: [g.y -> p.u]\nopen: [g.u]\n"
                   "experiment: {stop: 0.03, step: 0.01}\n", source="cap.yaml")
    Probe.told.clear()
    Execution(system, [ResultStore()], algorithm=Toy(stepped, rollback)).run()
    assert Probe.told == [(stepped, rollback)]


@pytest.mark.parametrize("retaken, period", [(True, None), (False, 0.5)])
def test_a_bus_block_keeps_its_log_while_steps_may_be_taken_again(tmp_path: Path, retaken: bool,
                                                                  period: float | None) -> None:
    bus = CanBus("can0")
    assert bus.check_peers({"can0": bus}) == []  # alone: a bus in run time
    bus.prepare(RunContext(tmp_path, 1e-3, False, steps_retaken=retaken))
    try:
        assert bus.log is not None and bus.log.period == period
    finally:
        bus.log.close()
