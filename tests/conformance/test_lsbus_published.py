"""FMU Manipulation Toolbox's FMI-LS-BUS CAN trio (a bus-simulation FMU and two node FMUs, FMI
3.0 with clocks; each node's `Rx_Data` is a Binary array of one element) wired as that tool's
own container wires them (`bus+nodes.json`: step 0.1 s), and node to node
(`nodes-only.json`): every operation a node or the bus sends, at its time, equal to the tool's
reference datalog. On our `can_bus` block, each node gets its Confirm and the other's frame."""
from __future__ import annotations

import csv
from pathlib import Path

import pytest

import twmr
from tests.conformance.corpus import corpus
from twmr.observers.ticks import read_ticks

pytestmark = pytest.mark.timeout(240)

NODE_TX = ["n1.CanChannel.Tx_Data", "n2.CanChannel.Tx_Data"]
#: the reference datalog's column -> our port
COLUMN = {"node1.CanChannel.Tx_Data": "n1.CanChannel.Tx_Data",
          "node2.CanChannel.Tx_Data": "n2.CanChannel.Tx_Data",
          "bus.Node1.Tx_Data": "bus.Node1.Tx_Data", "bus.Node2.Tx_Data": "bus.Node2.Tx_Data"}
Event = tuple[float, str, str]


def reference(path: Path) -> list[Event]:
    """(time, port, data hex) of every operation in a datalog of the tool: a node's Tx_Data at
    the rows where its Tx_Clock ticks, a bus terminal's Tx_Data where it changes (the datalog
    has no column of the bus's clocks)."""
    with path.open() as f:
        rows = list(csv.DictReader(f))
    events: set[Event] = set()
    last: dict[str, str] = {}
    for row in rows:
        t = float(row["time"])
        for column, port in COLUMN.items():
            data = row.get(column)
            if not data:
                continue
            if column.startswith("node"):
                clock = column.replace("Tx_Data", "Tx_Clock")
                if row[clock] == "1":
                    events.add((round(t, 6), port, data.lower()))
            elif data != last.get(column):
                events.add((round(t, 6), port, data.lower()))
            last[column] = data
    return sorted(events)


def ours(folder: Path) -> list[Event]:
    names, events, complete = read_ticks(folder / "ticks.arrows")
    assert complete
    return sorted({(round(t, 6), names[k], bytes(d).hex()) for t, k, d in events})


def run(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "trio.yaml"
    path.write_text(text)
    twmr.simulate(twmr.load(str(path)), out=str(tmp_path / "out"))
    return tmp_path / "out"


def test_bus_and_nodes_send_what_the_reference_datalog_shows(tmp_path: Path) -> None:
    folder = corpus("lsbus")
    out = run(tmp_path, f"""
components:
  bus: {{kind: fmu, parameters: {{path: {folder / 'bus.fmu'}}}}}
  n1: {{kind: fmu, parameters: {{path: {folder / 'node1.fmu'}}}}}
  n2: {{kind: fmu, parameters: {{path: {folder / 'node2.fmu'}}}}}
connections:
  - n1.CanChannel -> bus.Node1
  - n2.CanChannel -> bus.Node2
open: [bus.BusErrorProbability]
record: {{signals: [{', '.join(COLUMN.values())}]}}
experiment: {{start: 0.0, stop: 10.0, step: 0.1}}
""")
    expected, got = reference(folder / "REF-bus+nodes-datalog.csv"), ours(out)
    assert len(expected) > 190  # Configurations, then frames and confirms every 0.3 s
    assert got == expected
    # the bus confirms node 1's frame 0.48 ms after the tick, and node 2's 0.96 ms after it
    confirms = [(t, p) for t, p, d in got if p.startswith("bus.") and d.startswith("20")]
    assert confirms[:2] == [(0.30048, "bus.Node1.Tx_Data"), (0.30096, "bus.Node2.Tx_Data")]


def test_nodes_wired_to_each_other_send_what_the_reference_datalog_shows(tmp_path: Path
                                                                        ) -> None:
    folder = corpus("lsbus")
    out = run(tmp_path, f"""
components:
  n1: {{kind: fmu, parameters: {{path: {folder / 'node1.fmu'}}}}}
  n2: {{kind: fmu, parameters: {{path: {folder / 'node2.fmu'}}}}}
connections:
  - n1.CanChannel -> n2.CanChannel
record: {{signals: [{', '.join(NODE_TX)}]}}
experiment: {{start: 0.0, stop: 10.0, step: 0.1}}
""")
    assert ours(out) == reference(folder / "REF-nodes-only-datalog.csv")


def test_the_nodes_on_our_can_bus_block_each_get_a_confirm_and_the_others_frame(
        tmp_path: Path) -> None:
    folder = corpus("lsbus")
    out = run(tmp_path, f"""
components:
  bus: {{kind: can_bus}}
  n1: {{kind: fmu, parameters: {{path: {folder / 'node1.fmu'}}}}}
  n2: {{kind: fmu, parameters: {{path: {folder / 'node2.fmu'}}}}}
connections:
  - n1.CanChannel -> bus.n1
  - n2.CanChannel -> bus.n2
record: {{signals: [bus.n1.Tx_Data, bus.n2.Tx_Data]}}
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
""")
    frame, confirm = "1000000014000000010000000000040001020304", "200000000c00000001000000"
    got = ours(out)
    assert [t for t, _, _ in got] == [0.4, 0.4, 0.7, 0.7, 1.0, 1.0]
    for _, _, data in got:
        assert sorted([data[:len(frame)], data[len(frame):]] if data.startswith("1")
                      else [data[:len(confirm)], data[len(confirm):]]) == sorted([confirm, frame])


NODES_DBC = """VERSION ""
BS_:
BU_: Node1 Ecu
BO_ 1 NodeFrame: 4 Node1
 SG_ b0 : 0|8@1+ (1,0) [0|255] "" Ecu
 SG_ b1 : 8|8@1+ (1,0) [0|255] "" Ecu
 SG_ b2 : 16|8@1+ (1,0) [0|255] "" Ecu
 SG_ b3 : 24|8@1+ (1,0) [0|255] "" Ecu
BO_ 16 EcuFrame: 2 Ecu
 SG_ level : 0|16@1+ (0.5,0) [0|1000] "V" Node1
"""


def test_a_can_io_node_and_a_published_ls_bus_node_hear_each_other(tmp_path: Path) -> None:
    """The tool's node 1 (an FMI-LS-BUS FMU) and two `can_io` nodes of a database written for
    its frame on our `can_bus` block: the receiving node decodes node 1's 01 02 03 04 at each of
    its sends (0.3, 0.6, 0.9 s), and the frames the sending node puts on the bus reach node 1's
    terminal as LS-BUS Transmit operations of identifier 0x10 with its encoded value."""
    folder = corpus("lsbus")
    (tmp_path / "nodes.dbc").write_text(NODES_DBC)
    out = run(tmp_path, f"""
components:
  bus: {{kind: can_bus}}
  n1: {{kind: fmu, parameters: {{path: {folder / 'node1.fmu'}}}}}
  ecu: {{kind: can_io, parameters: {{dbc: nodes.dbc, receive: NodeFrame, bus: bus}}}}
  tx: {{kind: can_io, parameters: {{dbc: nodes.dbc, send: EcuFrame, bus: bus, period: 0.2}},
       initial: {{EcuFrame.level: 12.5}}}}
connections:
  - n1.CanChannel -> bus.n1
record: {{signals: [bus.n1.Tx_Data, ecu.NodeFrame.b0, ecu.NodeFrame.b3, ecu.NodeFrame.frames]}}
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
""")
    result = twmr.read_result(out)
    assert list(result["ecu.NodeFrame.frames"][-1:]) == [3]
    assert result["ecu.NodeFrame.b0"][-1] == 1 and result["ecu.NodeFrame.b3"][-1] == 4
    # CAN Transmit: op code 0x10, length 18, identifier 0x10, standard, data frame, 2 bytes,
    # 25 = 12.5 V / 0.5 (every field little-endian, as FMI-LS-BUS lays operations out)
    transmit = "10000000" "12000000" "10000000" "00" "00" "0200" "1900"
    to_node = [d for _, p, d in ours(out) if p == "bus.n1.Tx_Data"]
    assert sum(d.count(transmit) for d in to_node) == 5  # sent at 0, 0.2, ..., 0.8 s


def test_check_notes_the_pre_release_once_per_fmu(tmp_path: Path, capsys: pytest.CaptureFixture
                                                   ) -> None:
    """The trio says FMI-LS-BUS 1.0.0-beta.1 in each manifest and each Binary's MIME type: one
    note per FMU naming where, not one per variable."""
    from twmr.cli import main

    folder = corpus("lsbus")
    path = tmp_path / "trio.yaml"
    path.write_text(f"""
components:
  bus: {{kind: fmu, parameters: {{path: {folder / 'bus.fmu'}}}}}
  n1: {{kind: fmu, parameters: {{path: {folder / 'node1.fmu'}}}}}
  n2: {{kind: fmu, parameters: {{path: {folder / 'node2.fmu'}}}}}
connections:
  - n1.CanChannel -> bus.Node1
  - n2.CanChannel -> bus.Node2
open: [bus.BusErrorProbability]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
""")
    assert main(["check", str(path)]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if "pre-release" in line]
    assert len(notes) == 3
    assert "'bus.fmu' says FMI-LS-BUS 1.0.0-beta.1" in notes[0]
    assert "the MIME type of Node2.Rx_Data" in notes[0]
