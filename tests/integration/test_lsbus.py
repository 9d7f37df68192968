"""FMI-LS-BUS CAN nodes wired terminal to terminal (the "direct" composition): the frames each
node receives (identifier, data, time) are those its peer sends as documented (a CAN Transmit of
id 0x1 and data 01 02 03 04 every 300 ms, after two Configuration operations at the start);
manifest, MIME type and version checks; malformed bus operations named by FMU, terminal and time;
a terminal wired to a non-bus port refused at check."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from tests.fmu_build import build_lsbus_fmu
from twmr.core import CosimError
from twmr.fmi.lsbus import operations as ops
from twmr.master import simulate
from twmr.scenario import loads

MIME_VERSION = 'version=&quot;1.0.0&quot;'


@pytest.fixture(scope="module")
def nodes(tmp_path_factory) -> dict[str, str]:
    d = tmp_path_factory.mktemp("lsbus")
    return {n: str(build_lsbus_fmu(f"cannode_{n}", d)) for n in ("triggered", "countdown")}


def direct(a: str, b: str, extra: str = "", wire: str = "a.CanChannel -> b.CanChannel") -> str:
    """Node a (id 1, payload 01 02 03 04) and node b (id 0x22, payload 0a 0b 0c 0d), both every
    0.3 s; b's last received data wired to a third node's payload (a Binary wire)."""
    return f"""
components:
  a: {{kind: fmu, parameters: {{path: {a}{extra}}}}}
  b: {{kind: fmu, parameters: {{path: {b}, id: 0x22}}, initial: {{payload: "0a0b0c0d"}}}}
  c: {{kind: fmu, parameters: {{path: {b}, id: 0x33}}}}
connections:
  - {wire}
  - b.rx_payload -> c.payload
open: [a.payload, b.payload, c.CanChannel.Rx_*]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
"""


def rows(r, signal: str) -> dict[float, float]:
    return {round(float(t), 9): float(v) for t, v in zip(r["time"], r[signal], strict=True)}


@pytest.mark.parametrize("b_kind", ["triggered", "countdown"])
def test_two_nodes_exchange_their_frames_directly(nodes, b_kind) -> None:
    system = loads(direct(nodes["triggered"], nodes[b_kind]), source="direct.yaml")
    r = simulate(system)
    a, b, c = (system.components[n] for n in "abc")
    # a's frames (sent at 0.3, 0.6, 0.9) reach b at those communication points (rx_time);
    # b's count, read after its step, shows at the next point
    received = rows(r, "b.rx_frames")
    assert [received[t] for t in (0.0, 0.3, 0.4, 0.6, 0.7, 0.9, 1.0)] == [0, 0, 1, 1, 2, 2, 3]
    assert r["b.rx_id"][-1] == 0x1 and r["a.rx_id"][-1] == 0x22
    np.testing.assert_allclose([rows(r, "b.rx_time")[t] for t in (0.3, 0.4, 0.7, 1.0)],
                               [-1, 0.3, 0.6, 0.9], atol=1e-9)
    assert r["a.rx_frames"][-1] == 3 and r["b.rx_unknown"][-1] == r["a.rx_unknown"][-1] == 0
    assert b.get("rx_payload") == bytes([1, 2, 3, 4]) == c.get("payload")
    # what b's Rx_Data last held: a's frame alone; at the start, a's two configurations
    assert ops.decode(b.get("CanChannel.Rx_Data")) == [ops.CanTransmit(0x1, bytes([1, 2, 3, 4]))]
    assert [(t, p) for t, p in a._events.ticks if t < 0.25] == [(0.0, "CanChannel.Tx_Clock")]


def test_configuration_goes_out_at_the_start(nodes, tmp_path) -> None:
    """A triggered node's Tx data at t = 0 is its two Configuration operations."""
    system = loads(direct(nodes["triggered"], nodes["triggered"]).replace("stop: 1.0",
                                                                          "stop: 0.1"),
                   source="direct.yaml")
    simulate(system)
    assert ops.decode(system.components["b"].get("CanChannel.Rx_Data")) == [
        ops.Configuration(ops.CONFIG_CAN_BAUDRATE, 100000),
        ops.Configuration(ops.CONFIG_ARBITRATION_LOST_BEHAVIOR, ops.BUFFER_AND_RETRANSMIT)]


@pytest.mark.parametrize("fault, words", [
    (1, "length 21 runs past the end of the 20-byte buffer"),
    (2, "unknown operation code 0x99"),
])
def test_malformed_operations_name_fmu_terminal_and_time(nodes, fault, words) -> None:
    system = loads(direct(nodes["triggered"], nodes["triggered"], f", fault: {fault}"),
                   source="direct.yaml")
    with pytest.raises(CosimError) as err:
        simulate(system)
    text = str(err.value)
    assert "component 'a' at t = 0.3 s" in text and "bus terminal 'CanChannel'" in text
    assert "cannode_triggered.fmu" in text and words in text


def test_a_terminal_wired_to_a_port_is_refused_at_check(nodes) -> None:
    with pytest.raises(CosimError) as err:
        loads(direct(nodes["triggered"], nodes["triggered"], wire="a.CanChannel -> b.payload"),
              source="direct.yaml")
    assert "'a.CanChannel' is a bus terminal of 'a' and 'b.payload' is not a bus terminal" in \
        str(err.value)


def _check(tmp_path, fmu: str) -> subprocess.CompletedProcess:
    scenario = tmp_path / "bus.yaml"
    scenario.write_text(f"""
components:
  a: {{kind: fmu, parameters: {{path: {fmu}}}}}
  b: {{kind: fmu, parameters: {{path: {fmu}}}}}
connections: [a.CanChannel -> b.CanChannel]
open: [a.payload, b.payload]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
""")
    return subprocess.run([sys.executable, "-m", "twmr.cli", "check", str(scenario)],
                          capture_output=True, text=True)


@pytest.mark.parametrize("edits, words", [
    ({"fmi-ls-bus.can;": "fmi-ls-bus.lin;"},
     "has MIME type 'application/org.fmi-standard.fmi-ls-bus.lin; version=\"1.0.0\"', not CAN"),
    ({MIME_VERSION: 'version=&quot;2.0.0&quot;'}, "FMI-LS-BUS version '2.0.0'"),
    ({'fmi-ls-version="1.0.0"': 'fmi-ls-version="0.9"'}, "the LS-BUS manifest says"),
    ({'memberName="Rx_Clock"': 'memberName="RxClock"'}, "lacks member(s) Rx_Clock"),
])
def test_terminals_not_can_1_0_0_are_refused_at_check(tmp_path, edits, words) -> None:
    done = _check(tmp_path, str(build_lsbus_fmu("cannode_triggered", tmp_path, edits)))
    assert done.returncode != 0 and "Traceback" not in done.stderr
    assert "bus" in done.stderr and words in done.stderr, done.stderr


def test_a_beta_version_runs_with_a_note(tmp_path) -> None:
    beta = {MIME_VERSION: 'version=&quot;1.0.0-beta.1&quot;',
            'fmi-ls-version="1.0.0"': 'fmi-ls-version="1.0.0-beta.1"'}
    done = _check(tmp_path, str(build_lsbus_fmu("cannode_triggered", tmp_path, beta)))
    assert done.returncode == 0, done.stderr
    assert "note: component 'a'" in done.stderr and "FMI-LS-BUS 1.0.0-beta.1" in done.stderr
    assert "OK: the scenario is valid." in done.stdout


def test_two_nodes_through_the_bus_simulation_fmu(tmp_path) -> None:
    """Both nodes send at 0.3 and 0.6 s; the bus simulation (configured to 100 kbit/s by the
    nodes) lets id 0x1 win arbitration, holds the bus 44 + 32 = 76 bits (0.76 ms) per frame,
    confirms each frame to its sender and delivers it to the other node; the deliveries show at
    the first communication point (0.1 ms grid) at or after their time."""
    node = build_lsbus_fmu("cannode_triggered", tmp_path)
    bus = build_lsbus_fmu("canbus", tmp_path)
    system = loads(f"""
components:
  n1: {{kind: fmu, parameters: {{path: {node}}}}}
  n2: {{kind: fmu, parameters: {{path: {node}, id: 0x22}}, initial: {{payload: "0a0b0c0d"}}}}
  bus: {{kind: fmu, parameters: {{path: {bus}}}}}
connections:
  - n1.CanChannel -> bus.Node1
  - n2.CanChannel -> bus.Node2
open: [n1.payload, n2.payload]
experiment: {{start: 0.0, stop: 0.65, step: 0.0001}}
""", source="bus.yaml")
    r = simulate(system)
    frame = 76 / 100_000
    ends = [0.3 + frame, 0.3 + 2 * frame, 0.6 + frame, 0.6 + 2 * frame]
    ticks = system.components["bus"]._events.ticks
    np.testing.assert_allclose([t for t, p in ticks if p == "Node1.Tx_Clock"], ends, atol=1e-9)
    assert [t for t, p in ticks if p == "Node2.Tx_Clock"] == \
        [t for t, p in ticks if p == "Node1.Tx_Clock"]
    assert r["bus.baud"][-1] == 100_000 and r["bus.frames"][-1] == 4
    n1, n2 = system.components["n1"], system.components["n2"]
    assert (n2.get("rx_id"), n1.get("rx_id")) == (0x1, 0x22)
    np.testing.assert_allclose(sorted(set(r["n2.rx_time"])), [-1, 0.3008, 0.6008], atol=1e-9)
    np.testing.assert_allclose(sorted(set(r["n1.rx_time"])), [-1, 0.3016, 0.6016], atol=1e-9)
    assert r["n1.confirms"][-1] == r["n2.confirms"][-1] == 2
    assert r["n1.rx_frames"][-1] == r["n2.rx_frames"][-1] == 2


def test_an_isolated_node_exchanges_the_same_frames(nodes) -> None:
    """Node a (countdown) in a worker process of its own: the same frames at the same times."""
    results = [simulate(loads(direct(nodes["countdown"], nodes["triggered"], extra),
                              source="direct.yaml")) for extra in ("", ", isolate: true")]
    for signal in ("a.rx_frames", "a.rx_time", "b.rx_frames", "b.rx_id", "b.rx_time",
                   "a.CanChannel.Tx_Clock", "a.tx_time"):
        np.testing.assert_array_equal(results[0][signal], results[1][signal], signal)
    assert results[1]["b.rx_frames"][-1] == 3


def test_inspect_names_the_clocks_and_the_terminal(nodes) -> None:
    from twmr.fmi import describe_fmu, fmu_interface

    info = fmu_interface(nodes["countdown"])
    ports = {p["name"]: p for p in info["ports"]}
    assert ports["CanChannel.Tx_Clock"]["clock"] == "countdown"
    assert ports["CanChannel.Tx_Clock"]["scheduled"] and ports["CanChannel.Tx_Clock"]["kind"] == \
        "output"
    assert ports["CanChannel.Rx_Data"]["clocked_by"] == ["CanChannel.Rx_Clock"]
    assert info["bus_terminals"][0]["members"]["Tx_Data"] == "CanChannel.Tx_Data"
    assert "bus terminal CanChannel (CAN, FMI-LS-BUS 1.0.0)" in describe_fmu(nodes["countdown"])
