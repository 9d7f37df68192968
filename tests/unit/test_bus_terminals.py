"""Bus terminals of any component (`Component.terminals`): a wire between two terminals is the
wires of their members, each Tx to the other side's Rx, both ways; a terminal to a port is
refused naming both."""
from __future__ import annotations

from types import MappingProxyType

import pytest

from twmr.core import CosimError
from twmr.core.component import Component
from twmr.core.port import BINARY, CLOCK, Input, Output
from twmr.scenario import loads


class Node(Component):
    """A block with one bus terminal `can` (ports named as a bus block might name them)."""

    tx = Output(b"", type=BINARY)
    tx_tick = Output(False, type=CLOCK)
    rx = Input(b"", type=BINARY)
    rx_tick = Input(False, type=CLOCK)
    level = Input(0.0)
    terminals = MappingProxyType({"can": MappingProxyType({
        "Tx_Data": "tx", "Tx_Clock": "tx_tick", "Rx_Data": "rx", "Rx_Clock": "rx_tick"})})


@pytest.fixture(autouse=True)
def _allow_this_module(monkeypatch: pytest.MonkeyPatch) -> None:
    """The scenarios name this test module's block: allowed as a user would allow a package."""
    monkeypatch.setenv("TWMR_ALLOW_CODE", "tests")


def scenario(wire: str) -> str:
    return f"""
components:
  x: {{kind: "tests.unit.test_bus_terminals:Node"}}
  y: {{kind: "tests.unit.test_bus_terminals:Node"}}
connections:
  - {wire}
open: [x.level, y.level]
experiment: {{start: 0.0, stop: 0.1, step: 0.1}}
"""


def test_a_terminal_wire_is_four_member_wires() -> None:
    system = loads(scenario("x.can -> y.can"), source="terminals.yaml")
    assert sorted((c.src, c.src_port, c.dst, c.dst_port) for c in system.connections) == [
        ("x", "tx", "y", "rx"), ("x", "tx_tick", "y", "rx_tick"),
        ("y", "tx", "x", "rx"), ("y", "tx_tick", "x", "rx_tick")]


@pytest.mark.parametrize("wire, words", [
    ("x.can -> y.level", "'x.can' is a bus terminal of 'x' and 'y.level' is not a bus terminal"),
    ("x.tx_tick -> y.level", "'x.tx_tick' is a clock and 'y.level' is a Real port"),
])
def test_a_terminal_or_clock_to_a_value_is_refused(wire, words) -> None:
    with pytest.raises(CosimError) as err:
        loads(scenario(wire), source="terminals.yaml")
    assert words in str(err.value)
