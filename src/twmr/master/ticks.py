"""Binary ports recorded at their clocks' ticks (`record: signals`, e.g. `n1.CanChannel.Tx_Data`).

The step loop takes a recorded Binary port at every communication point where its clock is True,
whatever the decimation (a bus terminal's Tx_Data with its Tx_Clock, Rx_Data with its Rx_Clock,
another Binary port with the clock its model description names), and appends a `Tick` to its
rows; a Binary port without a clock is taken at every point and kept where its value changed.
`TickEvents` turns the ticks into the events the observers get, (time [s], signal, bytes): an
output's ticks inside the step that ends at the point keep their own times (`TickedData`; one
within `instant` of the point is put at the point), an input's tick is the point where the
component is given it.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

from twmr.core.port import BINARY
from twmr.fmi.lsbus.ticks import tick_parts
from twmr.observers.ticks import Event, instant
from twmr.scenario.system import System


@dataclass(frozen=True)
class Ticked:
    """A recorded Binary port, taken where its `clock` (component, port) is True; None: at
    every point."""

    name: str
    port: str
    clock: tuple[str, str] | None


class Tick(NamedTuple):
    """Recorded Binary port `k` held `value` at the communication point t [s]."""

    t: float
    k: int
    value: Any


def binary_signals(system: System, signals: Sequence[tuple[str, str]]) -> list[Ticked]:
    """The Binary ports among `signals`, in their order, each with its clock."""
    found = []
    for name, port in signals:
        comp = system.components[name]
        if comp.variables[port].type == BINARY:
            clock = comp.clock_of(port)
            found.append(Ticked(name, port, None if clock is None else (name, clock)))
    return found


class TickEvents:
    """The events of the ticks of `signals` (see the module docstring), in the order taken."""

    def __init__(self, system: System, signals: Sequence[Ticked]):
        self.names = [f"{s.name}.{s.port}" for s in signals]
        self._split = [system.components[s.name].variables[s.port].kind in ("output", "state")
                       for s in signals]
        self._clocked = [s.clock is not None for s in signals]
        self._last: list[Any] = [None] * len(signals)

    def events(self, ticks: Sequence[Tick]) -> list[Event]:
        out: list[Event] = []
        for t, k, value in ticks:
            if not self._clocked[k]:
                if value == self._last[k]:
                    continue
                self._last[k] = value
            data = b"" if value is None else value
            if self._split[k]:
                out += [(t if abs(at - t) <= instant(t) else at, k, part)
                        for at, part in tick_parts(data, t)]
            else:
                out.append((t, k, bytes(data)))
        return out
