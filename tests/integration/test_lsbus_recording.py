"""Recorded Binary (bus) ports: the test nodes' Tx_Data and Rx_Data, recorded at each tick of
their clocks, decode to the operations the nodes send (two Configurations at 0 s, then a CAN
Transmit every 0.3 s) and receive (the other node's frames, a Confirm through the bus block) at
the times `test_lsbus.py` and `test_lsbus_canbus_block.py` establish, whatever the decimation;
`to_pandas` gives `bytes`; the numeric rows do not change; the exports write or leave them out;
a killed run keeps the ticks written."""
from __future__ import annotations

import logging
import signal
import subprocess
import sys

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import twmr
from tests.fmu_build import build_c_fmu, build_lsbus_fmu
from tests.hostile.test_signals import signal_run
from twmr.fmi.lsbus import operations as ops
from twmr.observers.ticks import TickStream, TickTable, read_ticks

CONFIG = [ops.Configuration(ops.CONFIG_CAN_BAUDRATE, 100000),
          ops.Configuration(ops.CONFIG_ARBITRATION_LOST_BEHAVIOR, ops.BUFFER_AND_RETRANSMIT)]
A_FRAME = ops.CanTransmit(0x1, bytes([1, 2, 3, 4]))
B_FRAME = ops.CanTransmit(0x22, bytes([10, 11, 12, 13]))
PORTS = ["a.CanChannel.Tx_Data", "b.CanChannel.Rx_Data", "b.CanChannel.Tx_Data",
         "a.CanChannel.Rx_Data"]


@pytest.fixture(scope="module")
def nodes(tmp_path_factory) -> dict[str, str]:
    d = tmp_path_factory.mktemp("lsbus_rec")
    return {n: str(build_lsbus_fmu(f"cannode_{n}", d)) for n in ("triggered", "countdown")}


def direct(a: str, b: str, record: list[str], decimation: int = 1, stop: float = 1.0,
           step: float = 0.1) -> str:
    """Nodes a (id 1) and b (id 0x22) wired terminal to terminal, as in test_lsbus.py."""
    return f"""
components:
  a: {{kind: fmu, parameters: {{path: {a}}}}}
  b: {{kind: fmu, parameters: {{path: {b}, id: 0x22}}, initial: {{payload: "0a0b0c0d"}}}}
connections:
  - a.CanChannel -> b.CanChannel
open: [a.payload, b.payload]
record: {{signals: [{", ".join(record)}], decimation: {decimation}}}
experiment: {{start: 0.0, stop: {stop}, step: {step}}}
"""


def operations(r, port: str) -> list[tuple[float, list]]:
    return [(round(float(t), 9), ops.decode(data))
            for t, data in zip(r.tick_times(port), r[port], strict=True)]


@pytest.mark.parametrize("decimation", [1, 10])
@pytest.mark.parametrize("b_kind", ["triggered", "countdown"])
def test_tx_and_rx_data_are_the_operations_at_their_ticks(nodes, tmp_path, b_kind,
                                                          decimation) -> None:
    text = direct(nodes["triggered"], nodes[b_kind], [*PORTS, "b.rx_frames"], decimation)
    r = twmr.simulate(twmr.load(text), out=tmp_path / "out")
    assert len(r) == (11 if decimation == 1 else 2) and r.binary == PORTS
    # a triggered node configures at 0 s; a countdown node at its first tick, 0.3 s
    late = b_kind == "countdown"
    sent = {"a": [(0.0, CONFIG)] + [(t, [A_FRAME]) for t in (0.3, 0.6, 0.9)],
            "b": ([(0.3, [*CONFIG, B_FRAME])] if late else [(0.0, CONFIG), (0.3, [B_FRAME])])
            + [(t, [B_FRAME]) for t in (0.6, 0.9)]}
    for sender, receiver in (("a", "b"), ("b", "a")):
        assert operations(r, f"{sender}.CanChannel.Tx_Data") == sent[sender]
        assert operations(r, f"{receiver}.CanChannel.Rx_Data") == sent[sender]
    df = r.to_pandas()
    ticked = df[df["a.CanChannel.Tx_Data"].notna()]
    np.testing.assert_allclose(ticked.time, [0.0, 0.3, 0.6, 0.9], atol=1e-9)
    assert all(type(v) is bytes for v in ticked["b.CanChannel.Rx_Data"])
    assert df["a.CanChannel.Tx_Data"].isna().sum() == len(df) - 4
    # with decimation 10 the ticks at 0.3, 0.6 and 0.9 s are rows of their own
    assert len(df) == (11 if decimation == 1 else 5)
    assert df["b.rx_frames"].isna().sum() == (0 if decimation == 1 else 3)
    again = twmr.read_result(tmp_path / "out")
    assert operations(again, "b.CanChannel.Rx_Data") == operations(r, "b.CanChannel.Rx_Data")
    memory = twmr.simulate(twmr.load(text))
    assert operations(memory, "a.CanChannel.Tx_Data") == operations(r, "a.CanChannel.Tx_Data")


def test_recording_binary_ports_leaves_the_numeric_rows_as_they_were(nodes) -> None:
    numeric = ["b.rx_frames", "b.rx_time", "a.CanChannel.Tx_Clock"]
    plain = twmr.simulate(twmr.load(direct(nodes["triggered"], nodes["countdown"], numeric)))
    both = twmr.simulate(twmr.load(direct(nodes["triggered"], nodes["countdown"],
                                          [*PORTS, *numeric])))
    assert plain.columns == both.columns and not plain.binary
    assert plain.values.tobytes() == both.values.tobytes()
    assert list(plain.to_pandas().columns) == ["time", *numeric]


def test_a_wildcard_records_the_binary_ports(nodes) -> None:
    r = twmr.simulate(twmr.load(direct(nodes["triggered"], nodes["triggered"],
                                       ["a.CanChannel.*"])))
    assert sorted(r.binary) == ["a.CanChannel.Rx_Data", "a.CanChannel.Tx_Data"]
    assert "a.CanChannel.Tx_Clock" in r.columns


def test_a_binary_port_without_a_clock_is_kept_where_it_changes(nodes) -> None:
    """b's rx_payload (the data of the last frame it received) changes once: b reads a's
    frame at 0.3 s, in its step from there, so it shows at 0.4 s (as b.rx_frames does in
    test_lsbus.py)."""
    r = twmr.simulate(twmr.load(direct(nodes["triggered"], nodes["triggered"],
                                       ["b.rx_payload"])))
    np.testing.assert_allclose(r.tick_times("b.rx_payload"), [0.0, 0.4], atol=1e-9)
    assert list(r["b.rx_payload"]) == [b"", bytes([1, 2, 3, 4])]


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "adaptive"])
def test_ticks_inside_a_decimated_fine_grid_through_the_bus_block(nodes, algorithm) -> None:
    """On the bus block, a 0.1 ms grid recorded every 100 steps: n1's frame sent at 0.3 s,
    its Confirm at 0.3009 s and n2's frame, which lost arbitration, at 0.3017 s (the times of
    test_lsbus_canbus_block.py), none of them a recorded row; the adaptive master (its steps
    taken again where they passed an event) records the same ticks."""
    more = ", max_step: 0.05" if algorithm == "adaptive" else ""
    text = f"""
components:
  n1: {{kind: fmu, parameters: {{path: {nodes["triggered"]}}}}}
  n2: {{kind: fmu, parameters: {{path: {nodes["triggered"]}, id: 0x22}},
       initial: {{payload: "0a0b0c0d"}}}}
  bus: {{kind: can_bus}}
connections: [n1.CanChannel -> bus.n1, n2.CanChannel -> bus.n2]
open: [n1.payload, n2.payload]
record: {{signals: [n1.CanChannel.Tx_Data, n1.CanChannel.Rx_Data, n1.rx_frames],
          decimation: 100}}
experiment: {{start: 0.0, stop: 0.35, step: 0.0001, algorithm: {algorithm}{more}}}
"""
    r = twmr.simulate(twmr.load(text))
    assert len(r) == 36 if algorithm == "gauss_seidel" else len(r) < 100
    assert operations(r, "n1.CanChannel.Tx_Data") == [(0.0, CONFIG), (0.3, [A_FRAME])]
    assert operations(r, "n1.CanChannel.Rx_Data") == [(0.3009, [ops.Confirm(0x1)]),
                                                      (0.3017, [B_FRAME])]


def test_a_paced_run_records_the_same_ticks(nodes, tmp_path) -> None:
    """A paced run hands the rows and ticks to the observers from a thread of their own."""
    text = direct(nodes["triggered"], nodes["triggered"], PORTS, stop=0.7, step=0.05)
    paced = twmr.simulate(twmr.load(text.replace("step: 0.05}", "step: 0.05, realtime: true}")),
                          out=tmp_path / "paced")
    assert paced.summary["pacing"]["paced_steps"] == 14
    plain = twmr.simulate(twmr.load(text))
    for port in PORTS:
        assert operations(paced, port) == operations(plain, port)
    assert operations(paced, "b.CanChannel.Rx_Data")[1] == (0.3, [A_FRAME])


def test_the_exports_write_the_ticks_or_say_they_leave_them_out(nodes, tmp_path,
                                                                caplog) -> None:
    text = direct(nodes["triggered"], nodes["triggered"], ["a.CanChannel.Tx_Data",
                                                           "b.rx_frames"])
    with caplog.at_level(logging.WARNING, logger="twmr.run"):
        twmr.simulate(twmr.load(text), out=tmp_path / "out", formats=["csv", "parquet", "mat",
                                                                      "mcap"])
    out = tmp_path / "out"
    csv = pd.read_csv(out / "ticks.csv")
    assert list(csv.columns) == ["time", "a.CanChannel.Tx_Data"]
    assert ops.decode(bytes.fromhex(csv["a.CanChannel.Tx_Data"][1])) == [A_FRAME]
    assert list(pd.read_csv(out / "result.csv").columns) == ["time", "b.rx_frames"]
    table = pq.read_table(out / "ticks.parquet").to_pydict()
    assert ops.decode(table["a.CanChannel.Tx_Data"][0]) == CONFIG
    notes = [m for m in caplog.messages if "leaves out the recorded Binary ports" in m]
    assert [m.split()[1] for m in notes] == ["result.mat", "result.mcap"]
    assert operations(twmr.read_result(out / "result.mat"), "a.CanChannel.Tx_Data")[1] == \
        (0.3, [A_FRAME])


def test_ticks_stay_readable_when_their_last_batch_is_torn(tmp_path) -> None:
    stream = TickStream(tmp_path, ["x.Tx_Data", "y.Rx_Data"], sync_seconds=1.0)
    for k in range(4):
        stream.write([(0.1 * k, 0, bytes([k]) * 50), (0.1 * k, 1, b"rx")])
    stream.close()
    raw = (tmp_path / "ticks.arrows").read_bytes()
    (tmp_path / "ticks.arrows").write_bytes(raw[: len(raw) * 3 // 4])
    names, events, complete = read_ticks(tmp_path / "ticks.arrows")
    assert names == ["x.Tx_Data", "y.Rx_Data"] and not complete
    assert 0 < len(events) < 8 and events[0] == (0.0, 0, bytes(50))
    table = TickTable.of(names, events)
    assert table.values["y.Rx_Data"][0] == b"rx" and len(table) == len(events) // 2


def test_a_killed_run_keeps_the_ticks_it_wrote(nodes, tmp_path) -> None:
    scenario = tmp_path / "long.yaml"
    scenario.write_text(direct(nodes["triggered"], nodes["triggered"],
                               ["a.CanChannel.Tx_Data", "b.rx_frames"], decimation=100,
                               stop=10_000.0, step=0.001))
    signal_run(["run", str(scenario), "--out", "out", "-q"], tmp_path,
               "out.partial-*/ticks.arrows", 1.0, [(signal.SIGKILL, 0.0)])
    (partial,) = tmp_path.glob("out.partial-*")
    r = twmr.read_result(partial)
    found = operations(r, "a.CanChannel.Tx_Data")
    assert len(found) >= 2 and found[0] == (0.0, CONFIG)
    assert [o for _, o in found[1:]] == [[A_FRAME]] * (len(found) - 1)
    np.testing.assert_allclose([t for t, _ in found[1:]], 0.3 * np.arange(1, len(found)),
                               atol=1e-6)


def _twmr(args: list[str], cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "twmr.cli", *args], cwd=cwd,
                          capture_output=True, text=True)


def test_the_compiled_loop_on_refuses_a_binary_port_in_one_paragraph(nodes, tmp_path) -> None:
    scenario = tmp_path / "bus.yaml"
    scenario.write_text(direct(nodes["triggered"], nodes["triggered"],
                               ["a.CanChannel.Tx_Data", "b.rx_frames"]))
    done = _twmr(["run", str(scenario), "--out", "out", "--compiled", "on", "-q"], tmp_path)
    assert done.returncode != 0 and "Traceback" not in done.stderr
    assert "bus.yaml" in done.stderr and "record.signals" in done.stderr
    assert "'a.CanChannel.Tx_Data'" in done.stderr and "Fix: " in done.stderr, done.stderr
    assert len(done.stderr.strip().splitlines()) <= 3, done.stderr


def test_a_string_port_in_record_is_refused_naming_it(tmp_path) -> None:
    types3 = build_c_fmu("types3", tmp_path, fmi3=True)
    scenario = tmp_path / "text.yaml"
    scenario.write_text(f"""
components:
  a: {{kind: fmu, parameters: {{path: {types3}}}}}
open: [a.*]
record: {{signals: [a.Float64_output, a.String_output]}}
experiment: {{start: 0.0, stop: 0.3, step: 0.1}}
""")
    done = _twmr(["check", str(scenario)], tmp_path)
    assert done.returncode != 0 and "Traceback" not in done.stderr
    assert "text.yaml:5" in done.stderr and "a.String_output" in done.stderr, done.stderr
    assert "String port" in done.stderr and "Fix: " in done.stderr


def test_a_binary_output_without_a_clock_is_kept_where_it_changes(tmp_path) -> None:
    """An FMI 3.0 FMU without event mode whose Binary_output echoes Binary_input: kept at
    0 s, where it changes; the numbers as without it."""
    types3 = build_c_fmu("types3", tmp_path, fmi3=True)
    text = f"""
components:
  a: {{kind: fmu, parameters: {{path: {types3}}}, initial: {{Binary_input: "00ff10"}}}}
open: [a.*]
record: {{signals: [a.Float64_outputEXTRA]}}
experiment: {{start: 0.0, stop: 0.3, step: 0.1}}
"""
    r = twmr.simulate(twmr.load(text.replace("EXTRA", ", a.Binary_output")))
    assert list(r.tick_times("a.Binary_output")) == [0.0]
    assert r["a.Binary_output"][0] == bytes.fromhex("00ff10")
    plain = twmr.simulate(twmr.load(text.replace("EXTRA", "")))
    assert r.values.tobytes() == plain.values.tobytes()
