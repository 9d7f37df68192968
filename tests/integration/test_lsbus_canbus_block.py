"""FMI-LS-BUS CAN nodes on our bus block (`kind: can_bus`, the importer simulating the bus): the
test nodes (`tests/fmus/lsbus/cannode.c`: a CAN Transmit of id 1, or 0x22, with 4 data bytes
every 0.3 s after a Configuration of 100 kbit/s) exchange their frames with the end-of-frame
times the bit count of each frame at 100 kbit/s implies (counted here from the frame's bits, its
CRC-15 and the stuffing rule), the lower identifier first when both send at once, a Confirm to
the sender, an ACK error (Bus Error) for a node alone; malformed operations and bad wiring are
refused naming the FMU, the terminal, the time."""
from __future__ import annotations

import numpy as np
import pytest

from tests.can_frames import bits_to_eof, grid_after
from tests.fmu_build import build_lsbus_fmu
from twmr.core import CosimError
from twmr.fmi.lsbus import operations as ops
from twmr.hw.canbus import read_log
from twmr.master import simulate
from twmr.scenario import loads

RATE = 100_000  # bit/s, as the nodes configure
H = 1e-4


@pytest.fixture(scope="module")
def nodes(tmp_path_factory) -> dict[str, str]:
    d = tmp_path_factory.mktemp("lsbus_block")
    return {n: str(build_lsbus_fmu(f"cannode_{n}", d)) for n in ("triggered", "countdown")}


def scenario(a: str, b: str | None = None, extra: str = "", bus: str = "{kind: can_bus}",
             stop: float = 0.65, wires: str = "") -> str:
    """Node n1 (id 1, data 01 02 03 04) and, if `b`, node n2 (id 0x22, data 0a 0b 0c 0d) on
    the can_bus block `bus`."""
    second = f"  n2: {{kind: fmu, parameters: {{path: {b}, id: 0x22}}, initial: {{payload: " \
        f"\"0a0b0c0d\"}}}}\n" if b else ""
    return f"""
components:
  n1: {{kind: fmu, parameters: {{path: {a}{extra}}}}}
{second}  bus: {bus}
connections:
  - n1.CanChannel -> bus.n1
{"  - n2.CanChannel -> bus.n2" if b else ""}
{wires}
open: [n1.payload{", n2.payload" if b else ""}]
experiment: {{start: 0.0, stop: {stop}, step: {H}}}
"""


def values(r, signal: str) -> list[float]:
    return sorted({round(float(v), 9) for v in r[signal]})


@pytest.mark.parametrize("second", ["countdown", "triggered"])
def test_two_nodes_exchange_their_frames_through_the_bus_block(nodes, tmp_path, second) -> None:
    system = loads(scenario(nodes["triggered"], nodes[second]), source="bus.yaml")
    assert not system.paced
    r = simulate(system, tmp_path)
    first, other = bits_to_eof(0x1, bytes([1, 2, 3, 4])), bits_to_eof(0x22, bytes([10, 11, 12,
                                                                                  13]))
    log = read_log(tmp_path / "bus_frames.arrows")
    sent = log[log.event == "transmit"]
    assert list(sent.id) == [0x1, 0x22, 0x1, 0x22] and list(sent.sender) == ["n1", "n2"] * 2
    for k, t in enumerate((0.3, 0.6)):
        # both send at t: id 1 wins, 0x22 follows once the bus is free (3 intermission bits)
        np.testing.assert_allclose(sent.start.iloc[2 * k], t, atol=1e-9)
        np.testing.assert_allclose(sent.time.iloc[2 * k], t + first / RATE, atol=1e-9)
        np.testing.assert_allclose(sent.start.iloc[2 * k + 1], t + (first + 3) / RATE,
                                   atol=1e-9)
        np.testing.assert_allclose(sent.time.iloc[2 * k + 1], t + (first + 3 + other) / RATE,
                                   atol=1e-9)
    lost = log[log.event == "arbitration_lost"]
    assert list(lost.id) == [0x22, 0x22] and list(lost.sender) == ["n2", "n2"]
    np.testing.assert_allclose(lost.time, [0.3, 0.6], atol=1e-9)
    # each node receives the other's frame at the communication point at or after its end
    ends = sent.time.to_numpy()
    assert values(r, "n2.rx_time") == [-1.0, grid_after(ends[0]), grid_after(ends[2])]
    assert values(r, "n1.rx_time") == [-1.0, grid_after(ends[1]), grid_after(ends[3])]
    n1, n2 = system.components["n1"], system.components["n2"]
    assert (n2.get("rx_id"), n1.get("rx_id")) == (0x1, 0x22)
    assert r["n1.confirms"][-1] == r["n2.confirms"][-1] == 2
    assert r["n1.rx_frames"][-1] == r["n2.rx_frames"][-1] == 2
    assert r["n1.rx_unknown"][-1] == r["n2.rx_unknown"][-1] == 0
    assert r["bus.frames"][-1] == 4 and r["bus.errors"][-1] == 0 and r["bus.load"].max() > 0
    bus = system.components["bus"]
    assert bus.report()["frames"] == 4 and bus.report()["arbitration_lost"] == 2


def test_the_bus_block_in_run_time_is_the_same_every_run(nodes, tmp_path) -> None:
    logs = []
    for k in range(2):
        simulate(loads(scenario(nodes["countdown"], nodes["triggered"]), source="b.yaml"),
                 tmp_path / str(k))
        logs.append(read_log(tmp_path / str(k) / "bus_frames.arrows"))
    assert len(logs[0]) == 6
    assert logs[0].equals(logs[1])


def test_a_node_alone_gets_an_ack_error_as_a_bus_error(nodes, tmp_path) -> None:
    system = loads(scenario(nodes["triggered"], stop=0.35), source="alone.yaml")
    r = simulate(system, tmp_path)
    log = read_log(tmp_path / "bus_frames.arrows")
    assert list(log.event) == ["bus_error"] and log.detail[0].startswith("ACK error")
    np.testing.assert_allclose(log.time[0], 0.3 + bits_to_eof(1, bytes([1, 2, 3, 4])) / RATE,
                               atol=1e-9)
    told = system.components["bus"].get("n1.Tx_Data")
    assert ops.decode(told) == [ops.BusError(0x1, ops.ERROR_ACK, ops.FLAG_PRIMARY, True)]
    assert r["bus.errors"][-1] == 1 and r["n1.confirms"][-1] == 0
    assert values(r, "n1.bus_errors") == [0, 1]
    # the Bus Error reached the node with a tick of its Rx_Clock at the point after EOF
    ticks = r["bus.n1.Tx_Clock"]
    assert r["time"][np.flatnonzero(ticks)].tolist() == [grid_after(log.time[0])]


@pytest.mark.parametrize("fault, words", [
    (1, "length 21 runs past the end of the 20-byte buffer"),
    (2, "unknown operation code 0x99"),
])
def test_malformed_operations_name_fmu_terminal_and_time(nodes, fault, words) -> None:
    system = loads(scenario(nodes["triggered"], nodes["countdown"], f", fault: {fault}"),
                   source="bus.yaml")
    with pytest.raises(CosimError) as err:
        simulate(system)
    text = str(err.value)
    assert "component 'n1' at t = 0.3 s" in text and "bus terminal 'CanChannel'" in text
    assert "cannode_triggered.fmu" in text and words in text


@pytest.mark.parametrize("wires, words", [
    ("  - n1.CanChannel -> bus.frames",
     "'n1.CanChannel' is a bus terminal of 'n1' and 'bus.frames' is not a bus terminal"),
    ("  - bus.n1 -> bus2.n1", "'bus' and 'bus2' are both can_bus blocks: two buses joined"),
    ("  - bus.x -> bus2.y", "'bus2' and 'bus' are both can_bus blocks: two buses joined"),
    ("  - bus.n1 -> n1.payload", "'bus.n1' is a bus terminal of 'bus' and 'n1.payload' is not"),
    ("  - sim.Node1 -> bus.sim", "'sim' and 'bus' are both buses (a can_bus and a "
     "bus-simulation FMU): two buses joined"),
])
def test_bad_bus_wiring_is_refused_at_check(nodes, tmp_path, wires, words) -> None:
    sim = build_lsbus_fmu("canbus", tmp_path)
    text = scenario(nodes["triggered"], wires=wires).replace(
        "  bus: {kind: can_bus}\n", f"  bus: {{kind: can_bus}}\n  bus2: {{kind: can_bus}}\n"
        f"  sim: {{kind: fmu, parameters: {{path: {sim}}}}}\n")
    with pytest.raises(CosimError) as err:
        loads(text, source="bus.yaml")
    assert words in str(err.value)


def test_a_node_rate_other_than_the_bus_bitrate_stops_the_run(nodes) -> None:
    system = loads(scenario(nodes["triggered"], nodes["countdown"],
                            bus="{kind: can_bus, parameters: {bitrate: 500000}}"),
                   source="bus.yaml")
    with pytest.raises(CosimError) as err:
        simulate(system)
    text = str(err.value)
    assert "component 'bus' at t = 0 s" in text and "bus terminal 'n1'" in text
    assert "sets the bitrate to 100000 bit/s, but the bus runs at 500000 bit/s" in text


def test_an_lsbus_node_and_emulated_drives_share_a_paced_bus(nodes, tmp_path) -> None:
    """The bench scenario on a can_bus (emulated ODrives, paced) with a node on it at 1 Mbit/s:
    its frames (id 0x600, below every drive frame in priority) go on the wire after its ticks,
    each for the bits its frame has, confirmed to it; it hears the drives' frames."""
    from tests.integration.test_hw_canbus import bench

    text = bench(1.0, True).replace(
        "  plant:\n", f"  ecu:\n    kind: fmu\n    parameters: {{path: {nodes['triggered']}, "
        f"id: 0x600, bitrate: 1000000}}\n  plant:\n", 1)
    text = text.replace("connections:\n", "connections:\n  - ecu.CanChannel -> can0.ecu\n", 1)
    text = text.replace("record:\n", "open: [ecu.payload]\nrecord:\n", 1).replace(
        "  signals: [", "  signals: [ecu.rx_frames, ecu.confirms, ecu.tx_frames, "
        "ecu.bus_errors, ", 1)
    (tmp_path / "mixed.yaml").write_text(text)
    from twmr.api import read_result
    from twmr.api import simulate as run

    run(tmp_path / "mixed.yaml", out=tmp_path / "run")
    rows = read_result(tmp_path / "run").to_pandas()
    log = read_log(tmp_path / "run" / "can0_frames.arrows")
    sent = log[log.event == "transmit"]
    assert set(sent.sender) == {"motor", "motor (emulated)", "ecu"}
    ecu = sent[sent.sender == "ecu"]
    assert list(ecu.id) == [0x600] * 3
    assert np.all(ecu.start.to_numpy() >= np.array([0.3, 0.6, 0.9]) - 1e-6)
    np.testing.assert_allclose(ecu.time - ecu.start, bits_to_eof(0x600, bytes([1, 2, 3, 4]))
                               / 1e6, atol=1e-9)
    assert rows["ecu.tx_frames"].iloc[-1] == rows["ecu.confirms"].iloc[-1] == 3
    heard = rows["ecu.rx_frames"].iloc[-1]
    assert 0 < heard <= (sent.sender != "ecu").sum()
    assert rows["ecu.bus_errors"].max() == 0 and (log.event == "bus_error").sum() == 0


def test_the_adaptive_master_ends_its_steps_at_the_bus_events(nodes, tmp_path) -> None:
    """Under algorithm: adaptive the bus block announces the end of the frame on the wire
    (`next_event`) and saves its state: the same frames and deliveries as the fixed 0.1 ms
    step, in far fewer steps."""
    text = scenario(nodes["countdown"], nodes["triggered"]).replace(
        f"step: {H}}}", f"step: {H}, algorithm: adaptive, max_step: 0.05}}")
    fixed = simulate(loads(scenario(nodes["countdown"], nodes["triggered"]), source="f.yaml"),
                     tmp_path / "fixed")
    r = simulate(loads(text, source="adaptive.yaml"), tmp_path / "adaptive")
    assert len(r["time"]) < len(fixed["time"]) / 10
    log = read_log(tmp_path / "adaptive" / "bus_frames.arrows")
    assert log.equals(read_log(tmp_path / "fixed" / "bus_frames.arrows"))
    for signal in ("n1.rx_time", "n2.rx_time"):
        assert values(r, signal) == values(fixed, signal)


@pytest.mark.parametrize("wire, ok", [("n1.CanChannel -> bus.n1", True),
                                      ("n1.CanChannel -> bus.frames", False)])
def test_twmr_check_shows_the_member_wires_or_the_refusal(nodes, tmp_path, wire, ok) -> None:
    import subprocess
    import sys

    path = tmp_path / "bus.yaml"
    path.write_text(scenario(nodes["triggered"]).replace("n1.CanChannel -> bus.n1", wire))
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "check", str(path)],
                          capture_output=True, text=True)
    assert "Traceback" not in done.stderr
    if ok:
        assert done.returncode == 0, done.stderr
        for member in ("n1.CanChannel.Tx_Data -> bus.n1.Rx_Data",
                       "n1.CanChannel.Tx_Clock -> bus.n1.Rx_Clock",
                       "bus.n1.Tx_Data -> n1.CanChannel.Rx_Data",
                       "bus.n1.Tx_Clock -> n1.CanChannel.Rx_Clock"):
            assert member in done.stdout
    else:
        assert done.returncode != 0 and "is not a bus terminal" in done.stderr


@pytest.mark.parametrize("isolate", [False, True])
def test_a_tick_inside_a_step_keeps_its_time_on_the_bus(nodes, tmp_path, isolate) -> None:
    """A countdown node of 0.25 s on a 0.1 s grid: its frame goes on the wire at 0.25 s (its
    tick), though the block reads it at 0.3 s; its peer is told at the end of the block's next
    step, 0.4 s (docs/lsbus.md, Time)."""
    text = scenario(nodes["countdown"], nodes["triggered"],
                    f", period: 0.25, isolate: {str(isolate).lower()}", stop=0.5).replace(
        f"step: {H}", "step: 0.1")
    r = simulate(loads(text, source="tick.yaml"), tmp_path)
    log = read_log(tmp_path / "bus_frames.arrows")
    first = log[log.sender == "n1"].iloc[0]
    assert first.start == pytest.approx(0.25, abs=1e-9)
    assert first.time == pytest.approx(0.25 + bits_to_eof(1, bytes([1, 2, 3, 4])) / RATE,
                                       abs=1e-9)
    assert values(r, "n2.rx_time") == [-1.0, 0.4]


def test_a_flood_on_a_bus_in_run_time_is_noted_once_and_the_run_goes_on(nodes, tmp_path,
                                                                         caplog) -> None:
    """Node n1 sends id 1 every 0.2 ms at 100 kbit/s (a frame takes about 0.8 ms): n2's frame
    waits behind the queue; on a bus with nothing on the wall clock the watch notes the flood
    once (naming n1) and the run, a simulation, ends at its stop time."""
    text = scenario(nodes["triggered"], nodes["countdown"], ", period: 2.0e-4",
                    bus="{kind: can_bus, parameters: {flood_time: 0.01}}", stop=0.4)
    with caplog.at_level("WARNING", logger="twmr.hw.canbus_block"):
        r = simulate(loads(text, source="flood.yaml"), tmp_path)
    assert r["time"][-1] == pytest.approx(0.4)
    noted = [m for m in caplog.messages if "flooded" in m]
    assert len(noted) == 1 and "participant 'n1'" in noted[0], caplog.messages
